"""``serve://HOST:PORT/LINE``: a line of a ``robostar serve`` process, through its N1 face.

``HOST:PORT`` is the server's local API; opening asks it (``GET /lines/LINE/n1``) where the
line's N1 face listens (the API starts one on loopback when none is configured), then connects
there over TCP. Every client and CLI command thus works through the line server unchanged.
A token for a remote server goes in the ``token`` option (``serve://h:p/cell1?token=...``).
Reads through it are linearizable (answered by an exchange that began after they were sent);
``?max_age=S`` accepts values up to S seconds old from the server's model instead (the API
then hands out an N1 listener of its own whose reads do so).
An IPv6 address is written in brackets, as in any URL: ``serve://[::1]:8470/cell1``.
"""

from __future__ import annotations

import asyncio
import json
import urllib.error
import urllib.parse
import urllib.request

from robostar.errors import PortError
from robostar.transport.aio import AsyncTcpTransport, ReaderProtocol
from robostar.transport.tcp import TcpTransport
from robostar.transport.url import netloc

__all__ = ["AsyncServeTransport", "ServeTransport", "resolve_line", "serve_url"]

DEFAULT_API_PORT = 8470
"""The local API's port when a serve:// URL names none."""


def serve_url(api_host: str, api_port: int, line: str) -> str:
    """The ``serve://`` URL of ``line`` behind the API at ``api_host:api_port``."""
    return f"serve://{netloc(api_host, api_port)}/{line}"


def resolve_line(
    api_host: str,
    api_port: int,
    line: str,
    token: str | None,
    timeout: float,
    max_age: float | None = None,
) -> tuple[str, int]:
    """Ask the server's API where ``line``'s N1 face listens (one whose reads accept values
    ``max_age`` seconds old, when given); PortError saying why not."""
    where = serve_url(api_host, api_port, line)
    path = urllib.parse.quote(line, safe="")
    url = f"http://{netloc(api_host, api_port)}/lines/{path}/n1"
    if max_age is not None:
        url += f"?max_age={max_age!r}"
    request = urllib.request.Request(url)
    if token:
        request.add_header("Authorization", f"Bearer {token}")
    try:
        with urllib.request.urlopen(request, timeout=timeout) as reply:
            data = json.loads(reply.read())
    except urllib.error.HTTPError as exc:
        detail = exc.read().decode("utf-8", "replace")[:200]
        raise PortError(f"{where}: {exc.code} {detail}") from exc
    except (OSError, ValueError) as exc:
        raise PortError(
            f"{where}: no line server API there ({exc}); is robostar serve running with --api?"
        ) from exc
    address = data.get("n1") if isinstance(data, dict) else None
    if not isinstance(address, list) or len(address) != 2:
        raise PortError(f"{where}: the server gave no N1 address")
    return str(address[0]), int(address[1])


class ServeTransport(TcpTransport):
    """The blocking serve:// transport: resolve on open, then a plain TCP connection."""

    def __init__(
        self,
        api_host: str,
        api_port: int,
        line: str,
        *,
        token: str | None = None,
        connect_timeout: float = 5.0,
        url: str = "",
        max_age: float | None = None,
    ) -> None:
        url = url or serve_url(api_host, api_port, line)
        super().__init__(api_host, api_port, connect_timeout=connect_timeout, url=url)
        self.api = (api_host, api_port)
        self.line = line
        self.token = token
        self.max_age = max_age

    def open(self) -> None:
        if self.is_open:
            return
        self.host, self.port = resolve_line(
            *self.api, self.line, self.token, self.connect_timeout, self.max_age
        )
        super().open()


class AsyncServeTransport(AsyncTcpTransport):
    """The asyncio serve:// transport."""

    def __init__(
        self,
        api_host: str,
        api_port: int,
        line: str,
        *,
        token: str | None = None,
        connect_timeout: float = 5.0,
        url: str = "",
        max_age: float | None = None,
    ) -> None:
        url = url or serve_url(api_host, api_port, line)
        super().__init__(api_host, api_port, connect_timeout=connect_timeout, url=url)
        self.api = (api_host, api_port)
        self.line = line
        self.token = token
        self.max_age = max_age

    async def _connect(self) -> tuple[asyncio.BaseTransport, ReaderProtocol]:
        self.host, self.port = await asyncio.to_thread(
            resolve_line, *self.api, self.line, self.token, self.connect_timeout, self.max_age
        )
        return await super()._connect()
