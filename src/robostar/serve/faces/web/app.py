"""The dashboard as a Starlette application: pages, actions, the live event stream, the jog socket.

Everything is server-rendered (Jinja2) from the line server's model, and kept live by one
Server-Sent Events stream per browser (``/events``), fed by a bounded subscription of its own, so
a slow or frozen browser never slows the others or the line. State changes are POSTs that carry
the session's CSRF token and an explicit confirmation, need a role, and go through the line
server (lease and audit). Assets are served by the package: no CDN, plants are offline.
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import json
import math
import secrets
import time
import zipfile
from collections.abc import AsyncIterator, Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.middleware.sessions import SessionMiddleware
from starlette.requests import Request
from starlette.responses import (
    HTMLResponse,
    JSONResponse,
    RedirectResponse,
    Response,
    StreamingResponse,
)
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.templating import Jinja2Templates
from starlette.websockets import WebSocket, WebSocketDisconnect

from robostar.client.files import point_lines
from robostar.commands.base import Command
from robostar.commands.control import EmergencyStop, ResetAlarms, SetSpeed, StartJob, StopJob
from robostar.commands.files import DownloadFile, ListFiles, UploadFile
from robostar.commands.io import SetOutput
from robostar.commands.job import MAX_STEP, Servo
from robostar.errors import RobostarError, UsageError
from robostar.protocol.fields import FileName
from robostar.serve.faces.web.auth import (
    CSRF_FIELD,
    SESSION_LIFETIME,
    Account,
    LoginLimiter,
    SignInSessions,
    account_of,
    csrf_ok,
    read_form,
)
from robostar.serve.faces.web.jog import JogPanel
from robostar.serve.faces.web.limits import (
    DEFAULT_MAX_BODY,
    MAX_UPLOAD,
    MAX_UPLOAD_BODY,
    UPLOAD_ROUTES,
    upload_too_large,
)
from robostar.serve.faces.web.variables import KINDS, PAGE_MAX, build_write, page_range, read_rows
from robostar.serve.faces.web.views import axis_unit, change_json, sample_json
from robostar.serve.http_guard import (
    BodyLimit,
    BodyTooLarge,
    HostGuard,
    HostRule,
    Refusals,
    RouteLimit,
    same_secret,
)
from robostar.serve.jsonable import jsonable
from robostar.serve.lease import Who
from robostar.serve.line import Line, LineBusyError, LineDownError
from robostar.serve.line_server import LineServer
from robostar.serve.users import Role, UserStore
from robostar.types import (
    ArmForm,
    CoordSystem,
    FileRecord,
    JobFile,
    Point,
    PointFile,
    PositionKind,
    RobotType,
)

__all__ = ["WebSettings", "build_app"]

_HERE = Path(__file__).parent
EVENT_KEEPALIVE = 15.0
"""Seconds between SSE comments on a quiet stream, so proxies keep it open."""
SIGN_IN_ATTEMPTS_PER_ADDRESS = 20
"""Failed sign-ins from one address, whatever the names, in a minute (5 per address and name)."""
CONCURRENT_VERIFIES = 2
"""Password checks running at once (argon2 takes 64 MiB and a core's worth of time each)."""
WAITING_SIGN_INS = 32
"""Sign-ins waiting for a password check; more are told to try again."""


@dataclass(frozen=True, slots=True)
class WebSettings:
    """How the dashboard runs: its users, its cookie secret, and whether cookies need HTTPS."""

    users: UserStore
    secret: str
    https_only: bool = False
    audit_path: str | None = None
    listen_host: str = "127.0.0.1"
    """The address the dashboard listens on (with ``hosts``: the Host headers it answers)."""
    hosts: tuple[str, ...] = ()
    """Host names besides the listen address (the names a reverse proxy passes on)."""
    max_body: int = DEFAULT_MAX_BODY
    """The largest request body read, in bytes, on every route but the uploads (which take
    ``limits.MAX_UPLOAD_BODY``: the largest file the N1 protocol carries, and its form)."""


class _Forbidden(Exception):
    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


def build_app(server: LineServer, settings: WebSettings) -> Starlette:
    """The dashboard of ``server``'s lines."""
    templates = Jinja2Templates(directory=str(_HERE / "templates"))
    templates.env.globals["csrf_field"] = CSRF_FIELD
    templates.env.filters["clock"] = _clock
    limiter = LoginLimiter()  # per address and name: one user's lock-out spares the others
    address_limiter = LoginLimiter(attempts=SIGN_IN_ATTEMPTS_PER_ADDRESS)  # many names, one address
    verifying = asyncio.Semaphore(CONCURRENT_VERIFIES)
    waiting = 0
    users = settings.users
    sessions = SignInSessions()
    refusals = Refusals()

    def line_of(request: Request | WebSocket) -> Line:
        name = request.path_params["line"]
        line = server.lines.get(name)
        if line is None:
            raise _Forbidden(404, f"no line named {name!r}")
        return line

    def page(request: Request, template: str, /, **context: Any) -> HTMLResponse:
        account = account_of(request, users, sessions)
        return templates.TemplateResponse(
            request,
            template,
            {
                "account": account,
                "lines": list(server.lines.values()),
                "logins": len(users) > 0,
                **context,
            },
        )

    def refuse(line: Line | None, account: Account, what: str, status: int, why: str) -> NoReturn:
        """Refuse a request (_Forbidden), in the line's audit log when it names a line."""
        if line is not None:
            refusals.record(line, what, Who(account.name, "web"), why)
        raise _Forbidden(status, why)

    async def guard(request: Request, role: Role, line: Line | None, what: str) -> Account:
        """The account of a state-changing request, or _Forbidden (audited): the role first (no
        body is read for a visitor without it), then the CSRF token."""
        account = account_of(request, users, sessions)
        if not account.may(role):
            refuse(line, account, what, 403, _needs(role))
        if not await csrf_ok(request, account):
            refuse(line, account, what, 403, _STALE)
        return account

    def signed_in(request: Request, line: Line, what: str) -> Account:
        """The account of a GET that holds the line for file transfers (FA), or _Forbidden
        (audited): a signed-in user, a viewer at least. A GET carries no CSRF token, and any
        page the operator opens can fire one (an <img src=...>); the session cookie is
        SameSite=Strict, so such a request arrives anonymous and is refused here."""
        account = account_of(request, users, sessions)
        if not account.may(Role.VIEWER):
            refuse(line, account, what, 403, _needs(Role.VIEWER))
        return account

    transferring: set[str] = set()
    """Lines with a backup or file download for a browser running: one at a time per line, so
    browsers cannot queue transfer after transfer ahead of the writes of the other faces."""

    @contextlib.contextmanager
    def one_transfer(line: Line) -> Iterator[None]:
        if line.name in transferring:
            raise _Forbidden(
                429,
                f"line {line.name}: a backup or file download is already running;"
                " try again when it is done",
            )
        transferring.add(line.name)
        try:
            yield
        finally:
            transferring.discard(line.name)

    async def run(line: Line, command: Command[Any], account: Account) -> Any:
        who = Who(account.name, "web")
        return await line.execute(command, who=who, implicit_lease=True)

    # -- pages ---------------------------------------------------------------------------------
    async def overview(request: Request) -> Response:
        return page(request, "overview.html", cards=[_card(line) for line in server.lines.values()])

    async def controller(request: Request) -> Response:
        line = line_of(request)
        return page(request, "controller.html", line=line, card=_card(line), detail=_detail(line))

    async def files(request: Request) -> Response:
        line = line_of(request)
        channel = _int(request.query_params.get("channel", "1"), "channel", 1, 3)
        listing: tuple[FileRecord, ...] = ()
        error = None
        if not account_of(request, users, sessions).may(Role.VIEWER):
            # FD is a transfer too (up to 403 packets): not for a GET any page can fire
            error = "Sign in to list the files: the list is read from the controller."
        else:
            try:
                with one_transfer(line):
                    listing = await line.read(ListFiles(channel, "*"))
            except _Forbidden as exc:
                error = exc.message
            except RobostarError as exc:
                error = str(exc)
        return page(request, "files.html", line=line, channel=channel, files=listing, error=error)

    async def file_view(request: Request) -> Response:
        line = line_of(request)
        channel, name = _file_params(request)  # a bad name is a 400 for anyone: nothing sent
        signed_in(request, line, "file view")
        coords = CoordSystem.XY if request.query_params.get("coords") == "xy" else CoordSystem.ANGLE
        with one_transfer(line):
            content = await line.read(DownloadFile(channel, name, coords))
        return page(
            request,
            "file.html",
            line=line,
            channel=channel,
            name=str(name),
            job=content if isinstance(content, JobFile) else None,
            points=content if isinstance(content, PointFile) else None,
            coords=coords.name.lower(),
        )

    async def file_download(request: Request) -> Response:
        line = line_of(request)
        channel, name = _file_params(request)  # a bad name is a 400 for anyone: nothing sent
        signed_in(request, line, "file download")
        with one_transfer(line):
            content = await line.read(DownloadFile(channel, name, CoordSystem.ANGLE))
        text = _file_text(content)
        return Response(
            text,
            media_type="text/plain; charset=utf-8",
            headers={"content-disposition": f'attachment; filename="{name}"'},
        )

    async def point_edit(request: Request) -> Response:
        """The point table editor: one point of a PNT file changed, the file written back (FB)."""
        line = line_of(request)
        account = await guard(request, Role.ENGINEER, line, "point edit")
        channel, name = _file_params(request)
        form = await read_form(request)
        if form.get("confirmed") != "yes":
            raise _Forbidden(428, "confirm the change of the point first")
        if not name.is_points:
            raise _Forbidden(400, f"{name} is not a point file")
        number = _int(form.get("number"), "point", 0, 9999)
        content = await line.read(DownloadFile(channel, name, CoordSystem.ANGLE), max_age=0)
        if not isinstance(content, PointFile):
            raise _Forbidden(400, f"{name} did not download as a point table")
        old = content.points.get(number)
        count = len(old.axes) if old is not None else _axes_of(content)
        axes = tuple(_coordinate(form.get(f"axis{i}"), f"axis {i}") for i in range(1, count + 1))
        arm = old.arm if old is not None else ArmForm.NONE
        points = {**content.points, number: Point(axes, arm, True)}
        records = await line.read(ListFiles(channel, "*"), max_age=0)
        job_number = next((r.job_number for r in records if r.name == str(name)), 0)
        lines = point_lines(points)
        await run(line, UploadFile(channel, name, job_number, lines), account)
        return RedirectResponse(
            f"/line/{line.name}/files/{channel}/{name}?saved={number}", status_code=303
        )

    async def backup_zip(request: Request) -> Response:
        line = line_of(request)
        signed_in(request, line, "backup")
        buffer = io.BytesIO()
        with one_transfer(line), zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
            for channel in _channels(line):
                for record in await line.read(ListFiles(channel, "*")):
                    name = FileName.parse(record.name)
                    content = await line.read(DownloadFile(channel, name, CoordSystem.ANGLE))
                    archive.writestr(f"ch{channel}/{name}", _file_text(content))
        stamp = time.strftime("%Y%m%d-%H%M%S")
        return Response(
            buffer.getvalue(),
            media_type="application/zip",
            headers={"content-disposition": f'attachment; filename="{line.name}-{stamp}.zip"'},
        )

    async def upload_preview(request: Request) -> Response:
        line = line_of(request)
        await guard(request, Role.ENGINEER, line, "file upload")
        form = await read_form(request)
        channel = _int(str(form.get("channel", "1")), "channel", 1, 3)
        upload = form.get("file")
        if upload is None or isinstance(upload, str):
            raise _Forbidden(400, "choose a file to upload")
        raw = await upload.read(MAX_UPLOAD + 1)
        if len(raw) > MAX_UPLOAD:
            raise _Forbidden(413, upload_too_large("the file"))
        try:
            text = raw.decode("ascii")
        except UnicodeDecodeError:
            raise _Forbidden(400, "the controller holds ASCII text only") from None
        name = _file_name(str(form.get("name") or upload.filename or ""))
        lines = _steps(name, text)
        command = UploadFile(
            channel, name, _int(str(form.get("job_number", "0")), "job", 0, 200), lines
        )
        command.encode()  # every line checked now: a bad one is refused before the preview
        return page(
            request,
            "upload.html",
            line=line,
            channel=channel,
            name=str(name),
            job_number=command.job_number,
            lines=lines,
            content=text,
        )

    async def upload_confirm(request: Request) -> Response:
        line = line_of(request)
        account = await guard(request, Role.ENGINEER, line, "file upload")
        form = await read_form(request)
        if form.get("confirmed") != "yes":
            raise _Forbidden(428, "confirm the upload on its preview page")
        channel = _int(str(form.get("channel", "1")), "channel", 1, 3)
        name = _file_name(str(form.get("name", "")))
        job_number = _int(str(form.get("job_number", "0")), "job", 0, 200)
        content = str(form.get("content", ""))
        if len(content) > MAX_UPLOAD:  # the preview's limit, for a confirm sent without one
            raise _Forbidden(413, upload_too_large("the content"))
        lines = _steps(name, content)
        await run(line, UploadFile(channel, name, job_number, lines), account)
        return RedirectResponse(f"/line/{line.name}/files?channel={channel}", status_code=303)

    async def variables(request: Request) -> Response:
        """Global variables of one kind, a page of indexes read fresh from the controller."""
        line = line_of(request)
        query = request.query_params
        kind = query.get("kind", "int")
        if kind not in KINDS:
            raise _Forbidden(400, f"kind: one of {', '.join(KINDS)}")
        channel = _int(query.get("channel", "1"), "channel", 1, 3)
        start = _int(query.get("start", "0"), "start", 0, 1023)
        count = _int(query.get("count", "20"), "count", 1, PAGE_MAX)
        try:
            indexes = page_range(kind, start, count)
        except UsageError as exc:
            raise _Forbidden(400, str(exc)) from None
        rows = await read_rows(line, kind, channel, indexes)
        return page(
            request,
            "variables.html",
            line=line,
            kind=kind,
            kinds=KINDS,
            channel=channel,
            start=start,
            count=count,
            rows=rows,
            saved=query.get("saved"),
        )

    async def variable_write(request: Request) -> Response:
        """GW of one integer or float, confirmed, by an engineer, under the lease and audited."""
        line = line_of(request)
        account = await guard(request, Role.ENGINEER, line, "variable write")
        form = await read_form(request)
        if form.get("confirmed") != "yes":
            raise _Forbidden(428, "confirm the new value first")
        kind = str(form.get("kind", ""))
        index = _int(form.get("index"), "index", 0, 499)
        try:
            command = build_write(kind, index, str(form.get("value", "")))
            command.encode()  # the field's own checks, before the queue
        except UsageError as exc:
            raise _Forbidden(400, str(exc)) from None
        await run(line, command, account)
        start = _int(form.get("start", str(index)), "start", 0, 1023)
        return RedirectResponse(
            f"/line/{line.name}/variables?kind={kind}&start={start}&saved={index}",
            status_code=303,
        )

    async def jog_page(request: Request) -> Response:
        line = line_of(request)
        return page(request, "jog.html", line=line, card=_card(line))

    async def audit(request: Request) -> Response:
        return page(request, "audit.html", entries=_audit_tail(settings.audit_path, 200))

    async def health(request: Request) -> Response:
        return page(
            request, "health.html", health=[_health(line) for line in server.lines.values()]
        )

    # -- actions -------------------------------------------------------------------------------
    async def action(request: Request) -> Response:
        line = line_of(request)
        # the role every action needs and the CSRF header, before the body is read
        account = await guard(request, _ACTION_ROLE, line, "action")
        body = await _json_body(request)
        name = str(body.get("action", ""))
        spec = _ACTIONS.get(name)
        if spec is None:
            raise _Forbidden(400, f"unknown action {name!r}")
        if not account.may(spec.role):
            refuse(line, account, f"action {name}", 403, _needs(spec.role))
        if body.get("confirmed") is not True:
            raise _Forbidden(428, f"{name}: confirm it first")
        command = spec.build(body)
        result = await run(line, command, account)
        return JSONResponse({"ok": True, "action": name, "result": jsonable(result)})

    async def release(request: Request) -> Response:
        """Give the controller's lease back (only its holder can)."""
        line = line_of(request)
        account = await guard(request, Role.OPERATOR, line, "lease release")
        who = Who(account.name, "web")
        released = line.lease.release(who)
        # a change of who has control is part of the record, as the writes made under it are
        line.record("lease release", who, "ok" if released else "not held: nothing released")
        return JSONResponse({"ok": True, "released": released})

    # -- sign in and out -----------------------------------------------------------------------
    async def login_page(request: Request) -> Response:
        return page(request, "login.html", error=None)

    async def login(request: Request) -> Response:
        nonlocal waiting
        account = account_of(request, users, sessions)
        if not await csrf_ok(request, account):
            return page(request, "login.html", error="The form is stale: reload and try again.")
        form = await read_form(request)
        name = str(form.get("username", ""))
        address = request.client.host if request.client else "?"
        # per address and name (a user's lock-out spares the others at that address), and per
        # address alone (many names tried from one place)
        keys = ((limiter, f"{address}|{name}"), (address_limiter, address))

        def blocked() -> float:
            return max(which.blocked_for(key) for which, key in keys)

        if (wait := blocked()) > 0:
            return page(request, "login.html", error=f"Too many attempts: wait {wait:.0f} s.")
        if waiting >= WAITING_SIGN_INS:
            return page(request, "login.html", error="Too many sign-ins at once: try again.")
        waiting += 1
        try:
            async with verifying:  # a few argon2 checks at a time, however many ask
                if (wait := blocked()) > 0:  # failures while this one waited count too
                    return page(
                        request, "login.html", error=f"Too many attempts: wait {wait:.0f} s."
                    )
                password = str(form.get("password", ""))
                user = await asyncio.to_thread(users.verify, name, password)
        finally:
            waiting -= 1
        if user is None:
            for which, key in keys:
                which.failed(key)
            return page(request, "login.html", error="Wrong name or password.")
        limiter.succeeded(keys[0][1])  # this name's count only: the address's stays
        sessions.close(request.session.get("sid"))
        request.session.clear()
        request.session["user"] = user.name
        request.session["sid"] = sessions.open(user)
        request.session["csrf"] = secrets.token_urlsafe(32)  # a new session, a new token
        return RedirectResponse("/", status_code=303)

    async def logout(request: Request) -> Response:
        account = account_of(request, users, sessions)
        if await csrf_ok(request, account):
            sessions.close(request.session.get("sid"))  # the cookie, replayed, is anonymous
            request.session.clear()
        return RedirectResponse("/", status_code=303)

    # -- live ----------------------------------------------------------------------------------
    async def events(request: Request) -> Response:
        wanted = request.query_params.get("line")
        lines = [line for line in server.lines.values() if wanted in (None, line.name)]
        return StreamingResponse(
            _event_stream(request, lines),
            media_type="text/event-stream",
            headers={"cache-control": "no-store", "x-accel-buffering": "no"},
        )

    async def snapshot(request: Request) -> Response:
        line = line_of(request)
        values = {key: sample_json(sample) for key, sample in line.model.snapshot().items()}
        return JSONResponse({"line": line.name, "values": values})

    async def jog_socket(websocket: WebSocket) -> None:
        await _jog_socket(websocket, server, users, sessions, refusals)

    routes = [
        Route("/", overview),
        Route("/login", login_page, methods=["GET"]),
        Route("/login", login, methods=["POST"]),
        Route("/logout", logout, methods=["POST"]),
        Route("/events", events),
        Route("/audit", audit),
        Route("/health", health),
        Route("/line/{line}", controller),
        Route("/line/{line}/snapshot", snapshot),
        Route("/line/{line}/action", action, methods=["POST"]),
        Route("/line/{line}/release", release, methods=["POST"]),
        Route("/line/{line}/files", files),
        Route("/line/{line}/files/upload", upload_preview, methods=["POST"]),
        Route("/line/{line}/files/upload/confirm", upload_confirm, methods=["POST"]),
        Route("/line/{line}/files/{channel:int}/{name}", file_view),
        Route("/line/{line}/files/{channel:int}/{name}/download", file_download),
        Route("/line/{line}/files/{channel:int}/{name}/point", point_edit, methods=["POST"]),
        Route("/line/{line}/backup.zip", backup_zip),
        Route("/line/{line}/variables", variables, methods=["GET"]),
        Route("/line/{line}/variables", variable_write, methods=["POST"]),
        Route("/line/{line}/jog", jog_page),
        WebSocketRoute("/line/{line}/jog/ws", jog_socket),
        Mount("/static", StaticFiles(directory=str(_HERE / "static")), name="static"),
    ]
    middleware = [
        Middleware(
            HostGuard,
            rule=HostRule(settings.listen_host, settings.hosts),
            respond=_guard_error,
        ),
        Middleware(
            BodyLimit,
            limit=settings.max_body,
            respond=_guard_error,
            # the largest legitimate body is the largest file the protocol carries; every other
            # route is held to max_body (a sign-in, an action or a point: a few hundred bytes)
            routes=(RouteLimit(UPLOAD_ROUTES, MAX_UPLOAD_BODY, upload_too_large("the upload")),),
        ),
        Middleware(
            SessionMiddleware,
            secret_key=settings.secret,
            session_cookie="robostar_session",
            same_site="strict",
            https_only=settings.https_only,
            max_age=int(SESSION_LIFETIME),
        ),
    ]
    app = Starlette(
        routes=routes,
        middleware=middleware,
        exception_handlers={
            BodyTooLarge: _too_large_response,
            _Forbidden: _forbidden_response,
            RobostarError: _robostar_error_response,
        },
    )
    app.state.sessions = sessions
    app.state.transferring = transferring
    return app


# -- actions ---------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class _Action:
    role: Role
    build: Callable[[dict[str, Any]], Command[Any]]


def _channel(body: dict[str, Any]) -> int:
    return _int(body.get("channel"), "channel", 1, 3)


def _on(body: dict[str, Any]) -> bool:
    value = body.get("on")
    if not isinstance(value, bool):
        raise _Forbidden(400, "on: true or false")
    return value


_STALE = "the form is stale or forged (CSRF token missing or wrong)"


def _needs(role: Role) -> str:
    return f"this needs the {role.name.lower()} role; sign in first"


_ACTIONS: dict[str, _Action] = {
    "servo": _Action(Role.OPERATOR, lambda b: Servo(_channel(b), _on(b))),
    "job_start": _Action(Role.OPERATOR, lambda b: StartJob(_channel(b))),
    "job_stop": _Action(Role.OPERATOR, lambda b: StopJob(_channel(b))),
    "reset_alarms": _Action(Role.OPERATOR, lambda b: ResetAlarms()),
    "emergency_stop": _Action(Role.OPERATOR, lambda b: EmergencyStop()),
    "speed": _Action(
        Role.OPERATOR, lambda b: SetSpeed(_channel(b), _int(b.get("speed"), "speed", 0, 1000))
    ),
    "output": _Action(
        Role.OPERATOR,
        lambda b: SetOutput(
            _int(b.get("port"), "port", 0, 4), _int(b.get("contact"), "contact", 0, 15), _on(b)
        ),
    ),
}


_ACTION_ROLE = min(spec.role for spec in _ACTIONS.values())
"""The role every action needs at least (checked before the body is read)."""


# -- helpers ---------------------------------------------------------------------------------
def _clock(at: object) -> object:
    """An audit entry's ``time.time()`` as local date and time."""
    if isinstance(at, int | float):
        return time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(at))
    return at


def _int(value: object, name: str, low: int, high: int) -> int:
    if isinstance(value, bool):
        raise _Forbidden(400, f"{name}: a whole number {low}-{high}")
    try:
        number = int(str(value).strip())
    except ValueError:
        raise _Forbidden(400, f"{name}: a whole number {low}-{high}, not {value!r}") from None
    if not low <= number <= high:
        raise _Forbidden(400, f"{name}: {number} is not in {low}-{high}")
    return number


def _file_name(text: str) -> FileName:
    try:
        name = FileName.parse(text.strip())
        return name.check("", "name")
    except UsageError as exc:
        raise _Forbidden(400, str(exc)) from None


def _steps(name: FileName, text: str) -> tuple[str, ...]:
    """An uploaded file's lines, as FB will send them; a JOB of more steps than the protocol
    counts (FA could not even announce its length) is refused before anything is sent."""
    lines = tuple(text.splitlines())
    if name.is_job and len(lines) > MAX_STEP:
        raise _Forbidden(400, f"{name} has {len(lines)} lines; a job holds at most {MAX_STEP}")
    return lines


def _file_params(request: Request) -> tuple[int, FileName]:
    channel = _int(request.path_params["channel"], "channel", 1, 3)
    return channel, _file_name(request.path_params["name"])


def _file_text(content: JobFile | PointFile) -> str:
    if isinstance(content, JobFile):
        return "\n".join(content.lines) + "\n"
    return "\n".join(point_lines(content)) + "\n"


def _axes_of(content: PointFile) -> int:
    """How many axes a new point of this file has: as many as its other points."""
    return max((len(p.axes) for p in content.points.values()), default=4)


def _coordinate(value: object, name: str) -> float:
    try:
        number = float(str(value).strip())
    except ValueError:
        raise _Forbidden(400, f"{name}: a number, not {value!r}") from None
    if not math.isfinite(number) or abs(number) >= 1e6:
        raise _Forbidden(400, f"{name}: {value!r} is not a coordinate")
    if round(number, 3) != number:
        raise _Forbidden(400, f"{name}: at most 3 decimals ({value!r})")
    return number


async def _json_body(request: Request) -> dict[str, Any]:
    try:
        body = await request.json()
    except ValueError:
        raise _Forbidden(400, "the body is not JSON") from None
    if not isinstance(body, dict):
        raise _Forbidden(400, "the body must be a JSON object")
    return body


def _channels(line: Line) -> list[int]:
    """The channels to show and back up: the configured ones, else those the controller has
    (a channel AD reports NOT_DEFINED, with no axes, is none); all three until AD answered."""
    if line.config.channels or line.info is not None:
        return list(line.channels())
    return [1, 2, 3]


def _robot(line: Line, channel: int) -> RobotType | None:
    info = line.model.get("info")
    if info is None:
        return None
    for entry in getattr(info.value, "channels", ()):
        if entry.channel == channel:
            robot: RobotType = entry.robot_type
            return robot
    return None


def _card(line: Line) -> dict[str, Any]:
    """What an overview card shows of a line: online, and per channel the lamps and the job."""
    model = line.model
    names = getattr(line.config, "channels", {}) or {}
    channels = []
    for channel in _channels(line):
        prefix = f"ch{channel}/"
        channels.append(
            {
                "number": channel,
                "name": names.get(channel, f"channel {channel}"),
                "status": sample_json(model.get(prefix + "status")),
                "job": sample_json(model.get(prefix + "job")),
                "step": sample_json(model.get(prefix + "step")),
                "speed": sample_json(model.get(prefix + "speed")),
            }
        )
    return {
        "name": line.name,
        "online": sample_json(model.get("online")),
        "alarms": sample_json(model.get("alarms")),
        "channels": channels,
    }


def _detail(line: Line) -> dict[str, Any]:
    """The controller page beyond the card: positions with units, I/O, alarm history."""
    model = line.model
    axes = {}
    for channel in _channels(line):
        robot = _robot(line, channel)
        position = model.get(f"ch{channel}/position")
        values = list(position.value.axes) if position is not None else []
        axes[channel] = [
            {"axis": i + 1, "value": v, "unit": axis_unit(PositionKind.XY, i + 1, robot)}
            for i, v in enumerate(values)
        ]
    ports = []
    for port in range(5):
        inputs, outputs = model.get(f"io/in/{port}"), model.get(f"io/out/{port}")
        if inputs is None and outputs is None:
            continue
        ports.append({"port": port, "in": sample_json(inputs), "out": sample_json(outputs)})
    return {
        "info": sample_json(model.get("info")),
        "axes": axes,
        "ports": ports,
        "history": sample_json(model.get("alarm_history")),
    }


def _health(line: Line) -> dict[str, Any]:
    health = line.health
    latency = None if health.latency is None else f"{1000 * health.latency:.1f} ms"
    age = health.poll_age
    return {
        "name": line.name,
        "url": line.config.url,
        "up": health.up,
        "last error": health.last_error or "—",
        "last exchange": latency or "—",
        "exchanges": health.exchanges,
        "errors": health.errors,
        "reconnects": health.reconnects,
        "last poll": "—" if age is None else f"{age:.1f} s ago",
        "lease": str(line.lease.holder.who) if line.lease.holder else "free",
    }


def _audit_tail(path: str | None, count: int) -> list[dict[str, Any]]:
    """The last ``count`` audit entries, newest first (the file is JSON lines)."""
    if path is None or not Path(path).exists():
        return []
    with open(path, "rb") as handle:
        handle.seek(0, 2)
        size = handle.tell()
        handle.seek(max(0, size - 256 * 1024))
        tail = handle.read().decode("utf-8", "replace").splitlines()
    entries = []
    for text in reversed(tail[-count:]):
        with contextlib.suppress(ValueError):
            entry = json.loads(text)
            if isinstance(entry, dict):
                entries.append(entry)
    return entries


async def _event_stream(request: Request, lines: list[Line]) -> AsyncIterator[str]:
    """One browser's stream: a first snapshot, then every change of its lines' models."""
    subscriptions = [line.model.subscribe(maxsize=500) for line in lines]
    merged = asyncio.Queue[str](maxsize=1000)

    async def pump(line: Line, subscription: Any) -> None:
        async for change in subscription:
            text = json.dumps(change_json(line.name, change.key, change.sample))
            await merged.put(text)

    pairs = zip(lines, subscriptions, strict=True)
    tasks = [asyncio.create_task(pump(line, sub)) for line, sub in pairs]
    try:
        for line in lines:
            for key, sample in line.model.snapshot().items():
                yield f"event: change\ndata: {json.dumps(change_json(line.name, key, sample))}\n\n"
        while True:
            try:
                text = await asyncio.wait_for(merged.get(), EVENT_KEEPALIVE)
            except TimeoutError:
                if await request.is_disconnected():
                    return
                yield ": keepalive\n\n"
                continue
            yield f"event: change\ndata: {text}\n\n"
    finally:
        for task in tasks:
            task.cancel()
        for subscription in subscriptions:
            subscription.close()


async def _jog_socket(
    websocket: WebSocket,
    server: LineServer,
    users: UserStore,
    sessions: SignInSessions,
    refusals: Refusals,
) -> None:
    """The jog panel's socket: only an operator, with the page's CSRF token, from this origin."""
    name = websocket.path_params["line"]
    line = server.lines.get(name)
    account = account_of(websocket, users, sessions)
    origin = websocket.headers.get("origin")
    host = websocket.headers.get("host")
    token = websocket.query_params.get("csrf")
    same_origin = origin is not None and host is not None and origin.split("://", 1)[-1] == host
    why = None
    if not same_origin:
        why = "the jog socket was opened from another origin"
    elif not same_secret(token, account.csrf):
        why = _STALE
    elif not account.may(Role.OPERATOR):
        why = _needs(Role.OPERATOR)
    if line is None or why is not None:
        if line is not None and why is not None:
            refusals.record(line, "jog", Who(account.name, "web"), why)
        await websocket.close(code=4403)
        return
    await websocket.accept()

    def still_operator() -> bool:  # a sign-out, a removed user or a lowered role ends the jog
        return account_of(websocket, users, sessions).may(Role.OPERATOR)

    session = JogPanel(line, Who(account.name, "web"), still_operator)
    try:
        await session.run(websocket)
    except WebSocketDisconnect:
        pass
    finally:
        await session.stop("the page went away")


async def _forbidden_response(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, _Forbidden)
    return _error(request, exc.status, exc.message)


async def _too_large_response(request: Request, exc: Exception) -> Response:
    # a body without a length that grew past the limit (BodyLimit counted it)
    return _guard_error(413, str(getattr(exc, "detail", exc)))


async def _robostar_error_response(request: Request, exc: Exception) -> Response:
    # a line down or too busy to take one more read: try again later (not a conflict)
    status = 503 if isinstance(exc, LineDownError | LineBusyError) else 409
    return _error(request, status, str(exc))


def _guard_error(status: int, message: str) -> Response:
    return JSONResponse({"ok": False, "error": message}, status_code=status)


def _error(request: Request, status: int, message: str) -> Response:
    if "text/html" in request.headers.get("accept", "") and request.method == "GET":
        return HTMLResponse(f"<h1>{status}</h1><p>{_escape(message)}</p>", status_code=status)
    return JSONResponse({"ok": False, "error": message}, status_code=status)


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
