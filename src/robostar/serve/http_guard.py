"""Guards shared by the HTTP faces (the local API and the web dashboard).

- :class:`HostGuard`: ASGI middleware answering only requests whose ``Host`` header names this
  server (a page on another name that resolves here, DNS rebinding, gets a 400);
- :class:`BodyLimit`: ASGI middleware refusing a body past a size (413), by its
  ``Content-Length`` before any of it is read, and by counting what ``receive()`` hands over
  for a body without one (chunked), so no handler ever holds more than the limit; a route that
  carries a file may have a limit of its own (:class:`RouteLimit`), the rest stay tight;
- :func:`same_secret`: a constant-time comparison of two header or form values that never raises
  (a non-ASCII header is just a wrong one);
- :class:`Refusals`: a face's refusals into the line's audit log, rate-capped (a page sending
  cross-site requests in a loop must not fill the disk), what it skipped counted.

Which hosts are allowed (:class:`HostRule`): the listen address; for a loopback address also
``localhost``, ``127.0.0.1`` and ``::1``; for a wildcard address (``0.0.0.0``, ``::``) also any
IP literal (a rebinding attack always uses a name) and this machine's host name; plus the names in
the face's ``hosts`` option (``"*"`` there turns the check off).
"""

from __future__ import annotations

import hmac
import ipaddress
import re
import socket
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from starlette.exceptions import HTTPException
from starlette.responses import Response
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from robostar.errors import UsageError
from robostar.serve.ratelimit import TokenBucket

if TYPE_CHECKING:
    from robostar.serve.lease import Who
    from robostar.serve.line import Line

__all__ = [
    "DEFAULT_MAX_BODY",
    "BodyLimit",
    "BodyTooLarge",
    "HostGuard",
    "HostRule",
    "Refusals",
    "RouteLimit",
    "host_of",
    "hosts_option",
    "is_loopback_name",
    "max_body_option",
    "same_secret",
]

DEFAULT_MAX_BODY = 2 * 1024 * 1024
"""The largest request body the API reads (its ``max_body`` option): the largest legitimate one
is a file upload (9999 lines of at most 100 bytes, about 1 MB, as JSON). The dashboard keeps its
own limits, tight but for its upload routes (``robostar.serve.faces.web.limits``)."""

_LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")
_WILDCARDS = ("0.0.0.0", "::", "")

Respond = Callable[[int, str], Response]


def host_of(value: str | None) -> str | None:
    """The host part of a ``Host`` header (lower case, no port, no brackets); None if malformed."""
    if value is None:
        return None
    text = value.strip().lower()
    if not text:
        return None
    if text.startswith("["):
        end = text.find("]")
        if end < 0:
            return None
        host, rest = text[1:end], text[end + 1 :]
        if rest and not (rest.startswith(":") and rest[1:].isdigit()):
            return None
        return host or None
    if text.count(":") > 1:
        return None  # a bare IPv6 address is no Host header
    host, sep, port = text.partition(":")
    if sep and not port.isdigit():
        return None
    host = host.rstrip(".")
    if not host or any(c in host for c in "/@?#\\ "):
        return None
    return host


def _is_ip(text: str) -> bool:
    try:
        ipaddress.ip_address(text)
    except ValueError:
        return False
    return True


def is_loopback_name(host: str) -> bool:
    """``localhost`` or a loopback address, as written (no name is looked up)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class HostRule:
    """The host names a face listening on ``listen_host`` answers to (see the module's text)."""

    def __init__(self, listen_host: str, names: Iterable[str] = ()) -> None:
        listen = listen_host.strip("[]").lower()
        allowed = {listen}
        self.any_ip = listen in _WILDCARDS
        if is_loopback_name(listen) or self.any_ip:
            allowed.update(_LOOPBACK_NAMES)
        if self.any_ip:
            with_name = socket.gethostname().lower()
            if with_name:
                allowed.add(with_name)
        extra = [str(name).strip().lower().strip("[]").rstrip(".") for name in names]
        self.any_host = "*" in extra
        allowed.update(name for name in extra if name and name != "*")
        self.names = frozenset(allowed)

    def allows(self, host_header: str | None) -> bool:
        if self.any_host:
            return True
        host = host_of(host_header)
        if host is None:
            return False
        return host in self.names or (self.any_ip and _is_ip(host))


def hosts_option(value: object, face: str) -> tuple[str, ...]:
    """A face's ``hosts`` option: a list of names (or one name)."""
    if value is None:
        return ()
    if isinstance(value, str):
        return (value,)
    if isinstance(value, list | tuple) and all(isinstance(v, str) for v in value):
        return tuple(value)
    raise UsageError(f'{face}.hosts: expected a list of host names, e.g. ["cell7.plant.example"]')


def max_body_option(value: object, face: str, default: int = DEFAULT_MAX_BODY) -> int:
    """A face's ``max_body`` option: bytes, at least 64 KiB (``default`` when not given)."""
    if value is None:
        return default
    if isinstance(value, bool) or not isinstance(value, int) or value < 65536:
        raise UsageError(f"{face}.max_body: a number of bytes, at least 65536 (not {value!r})")
    return value


class BodyTooLarge(HTTPException):
    """Raised from ``receive()`` when a body without a length grows past the limit."""

    def __init__(self, limit: int, message: str | None = None) -> None:
        super().__init__(413, message or f"the request body is over {limit} bytes")


@dataclass(frozen=True, slots=True)
class RouteLimit:
    """A body limit of its own for the paths ``path`` matches in full (a file upload's), and
    what its 413 says (naming the limit)."""

    path: re.Pattern[str]
    limit: int
    message: str


class HostGuard:
    """ASGI middleware: a request (or WebSocket) whose Host the rule refuses gets a 400."""

    def __init__(self, app: ASGIApp, *, rule: HostRule, respond: Respond) -> None:
        self.app = app
        self.rule = rule
        self.respond = respond

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket") or self.rule.allows(_header(scope, b"host")):
            await self.app(scope, receive, send)
            return
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008})
            return
        host = (_header(scope, b"host") or "")[:100]
        message = f"this server does not answer to the host {host!r}"
        await self.respond(400, message)(scope, receive, send)


class BodyLimit:
    """ASGI middleware: at most ``limit`` bytes of request body reach the application (on a
    path one of ``routes`` matches, that route's limit)."""

    def __init__(
        self,
        app: ASGIApp,
        *,
        limit: int,
        respond: Respond,
        routes: Sequence[RouteLimit] = (),
    ) -> None:
        self.app = app
        self.limit = limit
        self.respond = respond
        self.routes = tuple(routes)

    def _limit_for(self, path: str) -> tuple[int, str]:
        for route in self.routes:
            if route.path.fullmatch(path):
                return route.limit, route.message
        return self.limit, f"the request body is over {self.limit} bytes"

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit, too_large = self._limit_for(str(scope.get("path", "")))
        length = _header(scope, b"content-length")
        if length is not None:
            if not length.strip().isdigit():
                await self.respond(400, "Content-Length is not a number")(scope, receive, send)
                return
            if int(length) > limit:
                await self.respond(413, too_large)(scope, receive, send)
                return
        received = 0

        async def counted() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise BodyTooLarge(limit, too_large)
            return message

        await self.app(scope, counted, send)


def _header(scope: Scope, name: bytes) -> str | None:
    headers: Any = scope.get("headers", ())
    for key, value in headers:
        if key == name:
            return bytes(value).decode("latin-1")
    return None


def same_secret(given: str | None, expected: str) -> bool:
    """``given == expected`` in constant time; False (never an error) for any odd value."""
    if given is None:
        return False
    return hmac.compare_digest(
        given.encode("utf-8", "surrogatepass"), expected.encode("utf-8", "surrogatepass")
    )


class Refusals:
    """Records a face's refusals with ``line.record``, at most ``rate`` a second (``burst`` at
    once); the next entry after a gap says how many were not recorded."""

    def __init__(
        self,
        rate: float = 10.0,
        burst: float = 100.0,
        *,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._bucket = TokenBucket(rate, burst, clock=clock)
        self.skipped = 0

    def record(self, line: Line, what: str, who: Who, why: str) -> None:
        if not self._bucket.take():
            self.skipped += 1
            return
        outcome = f"refused: {why}"
        if self.skipped:
            outcome += f" ({self.skipped} refusals before this one not recorded: too many)"
            self.skipped = 0
        line.record(what, who, outcome)
