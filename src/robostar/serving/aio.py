"""The asyncio host: N1 sessions on a TCP port, one per connection, on the running event loop.

:class:`AsyncHost` takes a factory that makes one byte peer per connection (usually a
:class:`~robostar.serving.session.Session` on a shared backend). Each connection is driven by
``loop.time()``: bytes in, the peer's bytes out, a timer at the peer's ``next_deadline()``, and
a pump soon after a backend answers late (the session's ``on_ready``). A connection whose peer
raises, or that leaves too much unread, is dropped with a log line; the others go on. Connections
past ``max_clients`` are closed at once with a log line.

Beyond loopback the N1 protocol has no authentication of its own, so a host can be told which
peers it serves: ``allow_from`` (addresses and networks; loopback is always allowed) and/or an
``ssl`` context (mutual TLS when the context requires client certificates).
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import logging
import socket
import ssl
from collections.abc import Callable, Iterable

from robostar.errors import UsageError
from robostar.serving.address import check_host, check_port
from robostar.serving.session import Session
from robostar.transport.peer import BytePeer

__all__ = ["AsyncHost", "parse_networks"]

Network = ipaddress.IPv4Network | ipaddress.IPv6Network

log = logging.getLogger(__name__)

MAX_PENDING = 1 << 20
"""A client that leaves this many bytes unread is dropped, so it cannot hold the server's memory."""


class _Connection(asyncio.Protocol):
    def __init__(self, owner: AsyncHost) -> None:
        self.owner = owner
        self.loop = asyncio.get_running_loop()
        self.transport: asyncio.Transport | None = None
        self.peer: BytePeer | None = None
        self.name = "?"
        self._timer: asyncio.TimerHandle | None = None
        self._scheduled = False

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        address = transport.get_extra_info("peername")
        self.name = f"{address[0]}:{address[1]}" if isinstance(address, tuple) else str(address)
        owner = self.owner
        if not owner.admits(address):
            log.warning("%s: refused %s: not in allow_from", owner.name, self.name)
            transport.abort()
            return
        if len(owner.connections) >= owner.max_clients:
            log.warning(
                "%s: refused %s: already %d clients (the limit)",
                owner.name,
                self.name,
                owner.max_clients,
            )
            transport.abort()
            return
        try:
            self.peer = owner.factory(self.name)
        except Exception:
            log.exception("%s: cannot open a session for %s", owner.name, self.name)
            transport.abort()
            return
        if isinstance(self.peer, Session):
            self.peer.on_ready = self._soon
        owner.connections.add(self)
        log.info("%s: client %s connected", owner.name, self.name)
        with contextlib.suppress(OSError, AttributeError):
            sock = transport.get_extra_info("socket")
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def data_received(self, data: bytes) -> None:
        peer = self.peer
        if peer is None:
            return
        try:
            peer.receive_data(data, self.loop.time())
        except Exception:
            self._fail()
            return
        self._pump()

    def _soon(self) -> None:
        if not self._scheduled:
            self._scheduled = True
            self.loop.call_soon(self._pump)

    def _pump(self) -> None:
        self._scheduled = False
        peer, transport = self.peer, self.transport
        if peer is None or transport is None or transport.is_closing():
            return
        try:
            out = peer.data_to_send(self.loop.time())
            deadline = peer.next_deadline()
        except Exception:
            self._fail()
            return
        if out:
            transport.write(out)
            if transport.get_write_buffer_size() > MAX_PENDING:
                log.warning("%s: %s does not read; dropped", self.owner.name, self.name)
                self._drop()
                return
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if deadline is not None:
            self._timer = self.loop.call_at(deadline, self._pump)

    def _fail(self) -> None:
        log.exception("%s: session of %s failed; dropped", self.owner.name, self.name)
        self._drop()

    def _drop(self) -> None:
        if self.transport is not None:
            self.transport.abort()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._timer is not None:
            self._timer.cancel()
        if self in self.owner.connections:
            self.owner.connections.discard(self)
            log.info("%s: client %s left", self.owner.name, self.name)
        if isinstance(self.peer, Session):
            self.peer.close()
        self.peer = None


def parse_networks(items: Iterable[object]) -> tuple[Network, ...]:
    """``["192.0.2.7", "198.51.100.0/24", "2001:db8::/32"]`` as networks (a bare address is /32)."""
    if isinstance(items, str | bytes):
        raise UsageError(f"allow_from: {items!r} is not a list of addresses or networks")
    networks: list[Network] = []
    for item in items:
        try:
            networks.append(ipaddress.ip_network(str(item).strip(), strict=False))
        except ValueError:
            raise UsageError(
                f"allow_from: {item!r} is not an address or network (e.g. 192.0.2.7, 10.1.0.0/16)"
            ) from None
    return tuple(networks)


class AsyncHost:
    """Serves one byte peer per TCP connection, made by ``factory(connection_name)``.

    ``await start(host, port)`` listens (loopback only unless ``allow_remote``) and returns the
    bound address; ``await close()`` stops listening and drops every connection.
    """

    def __init__(
        self,
        factory: Callable[[str], BytePeer],
        *,
        max_clients: int = 16,
        name: str = "n1",
    ) -> None:
        if isinstance(max_clients, bool) or not isinstance(max_clients, int) or max_clients < 1:
            raise UsageError(f"max_clients: {max_clients!r} is not 1 or more")
        self.factory = factory
        self.max_clients = max_clients
        self.name = name
        self.connections: set[_Connection] = set()
        self.allow_from: tuple[Network, ...] | None = None
        self._server: asyncio.Server | None = None

    def admits(self, peername: object) -> bool:
        """Whether a peer at ``peername`` (a socket address) may be served."""
        if self.allow_from is None:
            return True
        if not isinstance(peername, tuple) or not peername:
            return False
        try:
            address = ipaddress.ip_address(str(peername[0]).split("%")[0])
        except ValueError:
            return False
        if isinstance(address, ipaddress.IPv6Address) and address.ipv4_mapped is not None:
            address = address.ipv4_mapped
        return address.is_loopback or any(address in network for network in self.allow_from)

    @property
    def clients(self) -> int:
        return len(self.connections)

    async def start(
        self,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        allow_remote: bool = False,
        ssl_context: ssl.SSLContext | None = None,
        allow_from: Iterable[object] | None = None,
    ) -> tuple[str, int]:
        """Listen; ``allow_from`` limits the peers served (loopback always is), ``ssl_context``
        wraps every connection in TLS (the context decides whether client certificates are
        required)."""
        check_host(host, allow_remote)
        check_port(port)
        if self._server is not None:
            raise UsageError("start: the host is already serving")
        self.allow_from = None if allow_from is None else parse_networks(allow_from)
        loop = asyncio.get_running_loop()
        self._server = await loop.create_server(
            lambda: _Connection(self), host, port, ssl=ssl_context
        )
        bound = self._server.sockets[0].getsockname()
        return str(bound[0]), int(bound[1])

    async def close(self) -> None:
        server, self._server = self._server, None
        if server is not None:
            server.close()
        for connection in list(self.connections):
            connection._drop()
        # Aborted transports report connection_lost on the next loop turns.
        for _ in range(10):
            if not self.connections:
                break
            await asyncio.sleep(0)
        if server is not None:
            await server.wait_closed()

    async def __aenter__(self) -> AsyncHost:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()
