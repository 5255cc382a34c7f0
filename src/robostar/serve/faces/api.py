"""The local API face: JSON over HTTP and an SSE stream of model changes (Starlette + uvicorn).

Routes (``{line}`` is a line name)::

    GET    /lines                      every line: health, lease holder, N1 address
    GET    /lines/{line}               the line's model (every key: value, at, age, quality)
    GET    /lines/{line}/model/{key}   one key
    GET    /lines/{line}/events        Server-Sent Events, one ``change`` event per model change
    POST   /lines/{line}/commands      {"command": "SetSpeed", "args": {...}} or {"hex": "ff4141"}
    POST   /lines/{line}/lease         take or renew the lease; DELETE gives it up
    GET    /lines/{line}/n1            the line's N1 address (started on loopback on demand;
                                       what ``serve://HOST:PORT/LINE`` connects to;
                                       ``?max_age=S``: one whose reads accept values S s old)

A read (a command that changes nothing) is linearizable: answered by an exchange that began
after it arrived. With ``"max_age": S`` in the body (or ``?max_age=S``) a model value at most S
seconds old answers it; either way the answer gives its age, ``{"result": ..., "age_ms": ...}``.

The consumer names itself in the ``X-Robostar-Who`` header. A token, when configured (required
off loopback), goes in ``Authorization: Bearer TOKEN``.

What a web page must not do (a browser sends cross-site requests with the user's network access):
a POST or DELETE needs ``Content-Type: application/json`` (415 otherwise: a page's form or
``text/plain`` fetch cannot send it without a CORS preflight, which this API never grants), a
request whose ``Origin`` is not this API's own (``http://`` + its Host) is refused (403), and the
``Host`` header must name this server (400; see :mod:`robostar.serve.http_guard`), which
stops DNS rebinding. Bodies are at most ``max_body`` bytes (413). A lease's ``ttl`` is a finite
number of seconds, more than 0 and at most :data:`MAX_LEASE_TTL` (or the configured lease_ttl
when longer).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import time
from collections.abc import AsyncIterator, Mapping
from typing import TYPE_CHECKING, Any

from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import JSONResponse, Response, StreamingResponse
from starlette.routing import Route

from robostar.commands.base import Command
from robostar.commands.files import UploadFile
from robostar.commands.registry import all_commands, decode_request
from robostar.errors import ControllerError, RobostarError, UsageError
from robostar.listen import check_host, is_loopback, parse_listen, warn_remote
from robostar.serve.faces import Face, create_face
from robostar.serve.http_guard import (
    DEFAULT_MAX_BODY,
    BodyLimit,
    BodyTooLarge,
    HostGuard,
    HostRule,
    Refusals,
    hosts_option,
    max_body_option,
    same_secret,
)
from robostar.serve.jsonable import jsonable, sample_json
from robostar.serve.lease import LeaseHeldError, Who
from robostar.serve.line import Line, LineBusyError, LineDownError

if TYPE_CHECKING:
    from robostar.serve.line_server import LineServer

__all__ = ["ApiFace", "build_app", "create"]

log = logging.getLogger("robostar.serve.api")
_BY_NAME: dict[str, type[Command[Any]]] = {cls.__name__: cls for cls in all_commands()}
MAX_LEASE_TTL = 3600.0
"""The longest lease a consumer may ask for (``?ttl=``; the configured lease_ttl if longer)."""
MAX_EVENTS_QUEUE = 10_000
"""The largest ``?maxsize=`` of an event stream's queue."""
_SAFE_METHODS = frozenset(("GET", "HEAD", "OPTIONS"))


def _error(status: int, message: str, kind: str) -> JSONResponse:
    return JSONResponse({"error": kind, "message": message}, status_code=status)


class _Api:
    def __init__(self, server: LineServer, token: str | None) -> None:
        self.server = server
        self.token = token
        self.own_n1: dict[str, Face] = {}
        """N1 faces of the API's own, a line each, for serve:// (made through the face registry:
        faces never import each other)."""
        self.own_n1_starting = asyncio.Lock()

    def authorised(self, request: Request) -> bool:
        if self.token is None:
            return True
        return same_secret(request.headers.get("authorization", ""), f"Bearer {self.token}")

    @staticmethod
    def cross_site(request: Request) -> str | None:
        """Why a request looks like a web page's (a foreign Origin, a state change not sent as
        JSON), or None."""
        origin = request.headers.get("origin")
        if origin is not None:
            scheme, sep, rest = origin.partition("://")
            host = request.headers.get("host", "")
            if not sep or scheme.lower() != "http" or rest.lower() != host.lower():
                return f"a request from another origin ({origin[:100]!r}) is refused"
        if request.method not in _SAFE_METHODS:
            media = request.headers.get("content-type", "").split(";", 1)[0].strip().lower()
            if media != "application/json":
                return "a POST or DELETE needs 'Content-Type: application/json'"
        return None

    def line(self, request: Request) -> Line | None:
        return self.server.lines.get(request.path_params["line"])

    @staticmethod
    def who(request: Request) -> Who:
        client = request.client.host if request.client else "?"
        return Who(request.headers.get("x-robostar-who") or f"api:{client}", "api")

    def n1_address(self, name: str) -> tuple[str, int] | None:
        for face in (self.server.faces.get("n1"), self.own_n1.get(name)):
            if getattr(face, "ssl_context", None) is not None:
                continue  # robostar's serve:// client speaks plain TCP: it gets its own port
            addresses = getattr(face, "addresses", {})
            if name in addresses:
                return tuple(addresses[name])
        return None

    def line_json(self, line: Line) -> dict[str, Any]:
        holder = line.lease.holder
        health = line.health
        return {
            "name": line.name,
            "url": line.config.url,
            "up": line.up,
            "last_error": health.last_error,
            "latency": health.latency,
            "exchanges": health.exchanges,
            "errors": health.errors,
            "reconnects": health.reconnects,
            "poll_age": health.poll_age,
            "queue_depth": line.queue_depth,
            "lease": None
            if holder is None
            else {
                "who": holder.who.name,
                "face": holder.who.face,
                "since": holder.since,
                "expires_at": holder.expires_at,
            },
            "n1": self.n1_address(line.name),
        }


def build_app(
    server: LineServer,
    token: str | None = None,
    *,
    listen_host: str = "127.0.0.1",
    hosts: tuple[str, ...] = (),
    max_body: int = DEFAULT_MAX_BODY,
) -> Starlette:
    """The Starlette application of the API (also what tests drive with a TestClient: its
    ``testserver`` host must then be in ``hosts``)."""
    api = _Api(server, token)
    refusals = Refusals()

    def cross_site(request: Request, line: Line | None) -> Response | None:
        reason = api.cross_site(request)
        if reason is None:
            return None
        status, kind = (403, "origin") if "origin" in reason else (415, "content type")
        if line is not None:
            refusals.record(line, f"{request.method} {request.url.path}", api.who(request), reason)
        return _error(status, reason, kind)

    async def guard(request: Request) -> Response | tuple[_Api, Line]:
        if not api.authorised(request):
            return _error(401, "a valid 'Authorization: Bearer TOKEN' header is required", "auth")
        line = api.line(request)
        if line is None:
            names = ", ".join(server.lines)
            return _error(404, f"no line {request.path_params['line']!r} ({names})", "line")
        refusal = cross_site(request, line)
        if refusal is not None:
            return refusal
        return api, line

    async def lines(request: Request) -> Response:
        if not api.authorised(request):
            return _error(401, "a valid 'Authorization: Bearer TOKEN' header is required", "auth")
        refusal = cross_site(request, None)
        if refusal is not None:
            return refusal
        return JSONResponse([api.line_json(line) for line in server.lines.values()])

    async def model(request: Request) -> Response:
        got = await guard(request)
        if isinstance(got, Response):
            return got
        _, line = got
        snap = line.model.snapshot()
        return JSONResponse(
            {"line": api.line_json(line), "model": {k: sample_json(s) for k, s in snap.items()}}
        )

    async def model_key(request: Request) -> Response:
        got = await guard(request)
        if isinstance(got, Response):
            return got
        _, line = got
        sample = line.model.get(request.path_params["key"])
        if sample is None:
            return _error(404, f"no key {request.path_params['key']!r}", "key")
        return JSONResponse(sample_json(sample))

    async def events(request: Request) -> Response:
        got = await guard(request)
        if isinstance(got, Response):
            return got
        _, line = got
        maxsize = request.query_params.get("maxsize", "1000")
        if not maxsize.strip().isdigit() or not 1 <= int(maxsize) <= MAX_EVENTS_QUEUE:
            message = f"maxsize: a whole number 1-{MAX_EVENTS_QUEUE}, not {maxsize[:40]!r}"
            return _error(400, message, "usage")
        sub = line.model.subscribe(maxsize=int(maxsize))

        async def stream() -> AsyncIterator[str]:
            try:
                for key, sample in line.model.snapshot().items():
                    yield _sse(key, sample_json(sample))
                while True:
                    try:
                        change = await asyncio.wait_for(anext(sub), 15.0)
                    except TimeoutError:
                        yield ": keepalive\n\n"
                        continue
                    except StopAsyncIteration:
                        return
                    yield _sse(change.key, sample_json(change.sample))
            finally:
                sub.close()

        return StreamingResponse(stream(), media_type="text/event-stream")

    async def commands(request: Request) -> Response:
        got = await guard(request)
        if isinstance(got, Response):
            return got
        _, line = got
        try:
            body = await request.json()
            command = _command_from(body)
            # a read is linearizable unless it accepts an older value (the body's or the
            # query's max_age); it is then answered from the model, its age given with it
            max_age = _max_age(body.get("max_age", _query_number(request, "max_age")))
        except (ValueError, TypeError, RobostarError) as exc:
            return _error(400, str(exc), "usage")
        who = api.who(request)
        implicit = bool(body.get("implicit_lease", False))
        at: float | None = None
        try:
            if command.CHANGES_STATE:
                result = await line.execute(command, who=who, implicit_lease=implicit)
            else:
                result, at = await line.read_sample(command, max_age=max_age)
        except LeaseHeldError as exc:
            return _error(409, str(exc), "lease")
        except LineDownError as exc:
            return _error(503, str(exc), "line down")
        except LineBusyError as exc:
            return _error(503, str(exc), "line busy")
        except UsageError as exc:
            return _error(400, str(exc), "usage")
        except ControllerError as exc:
            return _error(422, str(exc), "controller")
        except RobostarError as exc:
            return _error(502, str(exc), type(exc).__name__)
        if at is None:
            return JSONResponse({"result": jsonable(result)})
        age_ms = round(max(0.0, time.time() - at) * 1000.0, 1)
        return JSONResponse({"result": jsonable(result), "age_ms": age_ms})

    async def lease(request: Request) -> Response:
        got = await guard(request)
        if isinstance(got, Response):
            return got
        _, line = got
        who = api.who(request)
        # who had control when is part of the record: every take, renewal, release and refusal
        # is in the audit log, as the writes made under the lease are
        if request.method == "DELETE":
            released = line.lease.release(who)
            line.record("lease release", who, "ok" if released else "not held: nothing released")
            return JSONResponse({"released": released})
        ttl = request.query_params.get("ttl")
        longest = max(MAX_LEASE_TTL, line.lease.ttl)
        seconds: float | None = None
        if ttl:
            try:
                seconds = float(ttl)
            except ValueError:
                seconds = math.nan
            if not math.isfinite(seconds) or not 0 < seconds <= longest:
                message = f"ttl: {ttl[:40]!r} is not a number of seconds > 0 and <= {longest:g}"
                return _error(400, message, "usage")
        what = "lease renew" if line.lease.held_by(who) else "lease take"
        try:
            info = line.lease.acquire(who, seconds)
        except LeaseHeldError as exc:
            line.record(what, who, f"refused: {exc}")
            return _error(409, str(exc), "lease")
        granted = line.lease.ttl if seconds is None else seconds
        line.record(what, who, f"ok: expires in {granted:g} s unless renewed")
        return JSONResponse({"who": who.name, "since": info.since, "expires_at": info.expires_at})

    async def n1(request: Request) -> Response:
        got = await guard(request)
        if isinstance(got, Response):
            return got
        _, line = got
        try:
            max_age = _max_age(_query_number(request, "max_age"))
        except UsageError as exc:
            return _error(400, str(exc), "usage")
        if max_age is not None:
            # serve://...?max_age=S: a listener of its own whose reads accept values S s old
            own = f"{line.name}?max_age={max_age:g}"
            async with api.own_n1_starting:
                if own not in api.own_n1:
                    options = {"lines": {line.name: "127.0.0.1:0"}, "max_age": max_age}
                    face = create_face("n1", server, options)
                    await face.start()
                    api.own_n1[own] = face
            addresses = getattr(api.own_n1[own], "addresses", {})
            return JSONResponse({"line": line.name, "n1": addresses.get(line.name)})
        address = api.n1_address(line.name)
        if address is None:
            async with api.own_n1_starting:
                if line.name not in api.own_n1:
                    face = create_face("n1", server, {"lines": {line.name: "127.0.0.1:0"}})
                    await face.start()
                    api.own_n1[line.name] = face
            address = api.n1_address(line.name)
        return JSONResponse({"line": line.name, "n1": address})

    async def too_large(request: Request, exc: Exception) -> Response:
        return _error(413, str(getattr(exc, "detail", exc)), "size")

    app = Starlette(
        routes=[
            Route("/lines", lines),
            Route("/lines/{line}", model),
            Route("/lines/{line}/model/{key:path}", model_key),
            Route("/lines/{line}/events", events),
            Route("/lines/{line}/commands", commands, methods=["POST"]),
            Route("/lines/{line}/lease", lease, methods=["POST", "DELETE"]),
            Route("/lines/{line}/n1", n1),
        ],
        middleware=[
            Middleware(HostGuard, rule=HostRule(listen_host, hosts), respond=_guard_error),
            Middleware(BodyLimit, limit=max_body, respond=_guard_error),
        ],
        exception_handlers={BodyTooLarge: too_large},
    )
    app.state.api = api
    return app


def _guard_error(status: int, message: str) -> Response:
    return _error(status, message, "size" if status == 413 else "request")


def _query_number(request: Request, name: str) -> float | str | None:
    """A number given in the query (as a float when it parses; the text otherwise, for
    :func:`_max_age` to refuse with its message), or None when absent."""
    text = request.query_params.get(name)
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        return text[:40]


def _max_age(value: Any) -> float | None:
    """A read's ``max_age``: None, or a finite number of seconds, 0 or more."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise UsageError(f"max_age: a number of seconds (0 or more) or null, not {value!r}")
    if value < 0:
        raise UsageError(f"max_age: {value!r} is negative")
    return float(value)


def _sse(key: str, data: dict[str, Any]) -> str:
    return f"event: change\ndata: {json.dumps({'key': key, **data})}\n\n"


def _command_from(body: Any) -> Command[Any]:
    if not isinstance(body, dict):
        raise UsageError('expected {"command": NAME, "args": {...}} or {"hex": "..."}')
    if "hex" in body:
        command = decode_request(bytes.fromhex(str(body["hex"])))
        if isinstance(command, UploadFile):
            # one packet is only FB's header: the file's lines follow in packets of their own,
            # so the request decodes as an upload of no lines, which would wipe the file
            raise UsageError(
                "hex: an FB request is only the upload's header (its lines follow in packets"
                ' of their own); send {"command": "UploadFile", "args": {"channel": ..., '
                '"file": ..., "job_number": ..., "lines": [...]}} instead'
            )
        return command
    name = body.get("command")
    cls = _BY_NAME.get(str(name))
    if cls is None:
        raise UsageError(f"command: {name!r} is not a command class name (e.g. ReadStatus)")
    args = body.get("args", {})
    if not isinstance(args, dict):
        raise UsageError("args: expected an object of the command's fields")
    command = cls(**args)
    command.encode()
    return command


class ApiFace:
    """Runs the API under uvicorn, inside the server's event loop."""

    def __init__(
        self,
        server: LineServer,
        listen: tuple[str, int],
        allow_remote: bool,
        token: str | None,
        *,
        hosts: tuple[str, ...] = (),
        max_body: int = DEFAULT_MAX_BODY,
    ) -> None:
        host = listen[0]
        if not is_loopback(host) and not token:
            raise UsageError("api: binding beyond loopback needs a token")
        check_host(host, allow_remote)
        self.listen = listen
        self.app = build_app(server, token, listen_host=host, hosts=hosts, max_body=max_body)
        self.address: tuple[str, int] | None = None
        self._uvicorn: Any = None
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        import uvicorn

        host, port = self.listen
        config = uvicorn.Config(
            self.app,
            host=host,
            port=port,
            log_level="warning",
            lifespan="off",
            proxy_headers=False,  # no proxy in front: the peer's address is the client's
        )
        self._uvicorn = uvicorn.Server(config)
        self._uvicorn.install_signal_handlers = lambda: None  # the CLI owns the signals
        self._task = asyncio.create_task(self._uvicorn.serve())
        while not self._uvicorn.started:
            if self._task.done():
                self._task.result()
                raise UsageError(f"api: could not listen on {host}:{port}")
            await asyncio.sleep(0.01)
        sock = self._uvicorn.servers[0].sockets[0]
        bound = sock.getsockname()
        self.address = (str(bound[0]), int(bound[1]))
        warn_remote(host, self.address[1], "the local API")
        log.info("api on http://%s:%d", *self.address)

    async def stop(self) -> None:
        if self._uvicorn is not None:
            self._uvicorn.should_exit = True
            self._uvicorn.force_exit = True
        if self._task is not None:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._task, 5)
            self._task = None
        own = self.app.state.api.own_n1
        for face in own.values():
            await face.stop()
        own.clear()


def create(server: LineServer, options: Mapping[str, Any]) -> ApiFace:
    """``options``: ``{"listen": "HOST:PORT", "allow_remote": bool, "token": str, "hosts": [names
    besides the listen address], "max_body": bytes}``."""
    listen = options.get("listen")
    if not isinstance(listen, str):
        raise UsageError('api.listen: expected "HOST:PORT"')
    token = options.get("token")
    return ApiFace(
        server,
        parse_listen(listen),
        bool(options.get("allow_remote", False)),
        str(token) if token else None,
        hosts=hosts_option(options.get("hosts"), "api"),
        max_body=max_body_option(options.get("max_body"), "api"),
    )
