"""The N1 face's listeners: one :class:`~robostar.serve.faces.n1.host.AsyncHost` per line, each
session's requests handed to the line by a :class:`~robostar.serve.faces.n1.backend.N1Backend`
(and used by serve:// on demand, through the API face)."""

from __future__ import annotations

import logging
import ssl
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from robostar.controller_role.limits import HostLimits
from robostar.controller_role.session import ControllerSession
from robostar.listen import warn_remote
from robostar.serve.faces.n1.backend import N1Backend
from robostar.serve.faces.n1.host import AsyncHost

if TYPE_CHECKING:
    from robostar.serve.line_server import LineServer

__all__ = ["N1Face"]

log = logging.getLogger("robostar.serve.n1")


class N1Face:
    """One :class:`AsyncHost` per configured line."""

    def __init__(
        self,
        server: LineServer,
        listens: Mapping[str, tuple[str, int]],
        allow_remote: bool,
        *,
        ssl_context: ssl.SSLContext | None = None,
        allow_from: Sequence[object] | None = None,
        limits: HostLimits | None = None,
        max_age: float | None = None,
    ) -> None:
        self.server = server
        self.limits = limits or HostLimits()
        self.listens = dict(listens)
        self.allow_remote = allow_remote
        self.ssl_context = ssl_context
        self.allow_from = allow_from
        self.hosts: dict[str, AsyncHost] = {}
        self.backends: dict[str, N1Backend] = {}
        self.addresses: dict[str, tuple[str, int]] = {}
        self.max_age = max_age
        """Seconds old a model value may be to answer a read (None: reads are linearizable)."""

    async def start(self) -> None:
        for name, listen in self.listens.items():
            await self.add_line(name, listen)

    async def add_line(self, name: str, listen: tuple[str, int]) -> tuple[str, int]:
        """Serve line ``name`` on ``listen`` (once; the address it is served on)."""
        if name in self.addresses:
            return self.addresses[name]
        host, port = listen
        backend = N1Backend(self.server.lines[name], max_age=self.max_age)
        timeout = self.server.lines[name].config.timeout

        def factory(conn: str) -> ControllerSession:
            return backend.session(conn, timeout)

        n1 = AsyncHost(
            factory,
            name=f"n1 {name}",
            max_clients=self.limits.max_clients,
            idle_timeout=self.limits.idle_timeout,
        )
        self.addresses[name] = await n1.start(
            host,
            port,
            allow_remote=self.allow_remote,
            ssl_context=self.ssl_context,
            allow_from=self.allow_from,
        )
        warn_remote(host, self.addresses[name][1], f"the N1 face of line {name}")
        self.hosts[name] = n1
        self.backends[name] = backend
        log.info("n1 face: line %s on %s:%d", name, *self.addresses[name])
        return self.addresses[name]

    async def stop(self) -> None:
        for name, n1 in self.hosts.items():
            await n1.close()
            await self.backends[name].drain()
        self.hosts.clear()
        self.addresses.clear()
