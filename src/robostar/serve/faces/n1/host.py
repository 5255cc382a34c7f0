"""The asyncio host: N1 sessions on a TCP port, one per connection, on the running event loop.

:class:`AsyncHost` takes a factory that makes one byte peer per connection (usually a
:class:`~robostar.controller_role.session.ControllerSession` on a shared backend). Each connection
is driven by ``loop.time()``: bytes in, the peer's bytes out, a timer at the peer's
``next_deadline()``, and a pump soon after a backend answers late (the session's ``on_ready``). A
connection whose peer raises, or that leaves too much unread, is dropped with a log line; the others
go on.

Slots are held only by connections in use: each socket has TCP keepalive with short probes (a
peer that vanished, power cut or cable pulled, is found within about half a minute) and a
connection that sends nothing for ``idle_timeout`` seconds is closed. A connection past
``max_clients`` gets a session of its own that refuses every request (flag 0x32, KD saying why)
until it falls silent for a second, so its host program learns that nothing was done, instead
of seeing the connection vanish after it sent a request (which it must take as "outcome
unknown").

A connection is named before its session is made (the line's audit and lease name the session's
host by it, so it never changes): by its client certificate, else, for a peer on this machine, by
the user and process that hold its socket. Finding those reads ``/proc`` (tens of ms), so it runs
in a worker thread while the loop serves everyone else; bytes the host sends meanwhile wait in a
buffer and are fed to the session once it exists. The connection holds its slot (``max_clients``)
from the start, and the idle limit and a close apply to it during the lookup as after.

Beyond loopback the N1 protocol has no authentication of its own, so a host can be told which
peers it serves: ``allow_from`` (addresses and networks; loopback is always allowed) and/or an
``ssl`` context (mutual TLS when the context requires client certificates).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import functools
import logging
import socket
import ssl
from collections.abc import Callable, Iterable

from robostar.commands.files import UploadFile
from robostar.commands.system import ReadLastError
from robostar.controller_role.limits import (
    IDLE_TIMEOUT,
    MAX_CLIENTS,
    MAX_PENDING,
    check_limits,
)
from robostar.controller_role.session import Backend, ControllerSession, Refusal, Request
from robostar.errors import UsageError
from robostar.listen import Network, admits, check_host, check_port, parse_networks
from robostar.protocol.fields import FLAG_FAILED
from robostar.serve.faces.n1 import peer_owner
from robostar.serve.faces.n1.peer_owner import PeerOwner, lookup_due, peer_name
from robostar.transport.peer import BytePeer

__all__ = ["AsyncHost"]

log = logging.getLogger(__name__)

KEEPALIVE_IDLE = 15
"""Seconds of silence before the first TCP keepalive probe (Linux: TCP_KEEPIDLE)."""
KEEPALIVE_INTERVAL = 5
"""Seconds between probes (TCP_KEEPINTVL)."""
KEEPALIVE_COUNT = 3
"""Unanswered probes before the kernel drops the connection (TCP_KEEPCNT): a peer that vanished
without a FIN (power cut, cable pulled) is found within 15 + 3 x 5 = 30 s, not hours."""
TURN_AWAY_IDLE = 1.0
"""Seconds of silence after which a connection past ``max_clients`` is closed: a host program
sends its request as soon as it connects, and its KD right after the refusal."""
TURN_AWAY_MAX = 10.0
"""Seconds a connection past ``max_clients`` is kept at most, however busy it is."""
_lookup_thread: concurrent.futures.ThreadPoolExecutor | None = None


def _lookups() -> concurrent.futures.ThreadPoolExecutor:
    """The one thread that looks connections' owners up, one after the other: a lookup is
    Python code as much as system calls, so several at once would take the interpreter from
    the event loop in turn (the rate limit bounds how many a second)."""
    global _lookup_thread
    if _lookup_thread is None:
        _lookup_thread = concurrent.futures.ThreadPoolExecutor(1, "n1-peer-owner")
    return _lookup_thread


NAMING_BUFFER = 1 << 16
"""Bytes kept from a connection while its name is looked up; past this it is not read until
its session exists (a host program sends one request, a few hundred bytes, then waits)."""


def _keepalive(sock: socket.socket) -> None:
    """TCP keepalive with short probes where the system lets us set them (Linux does; elsewhere
    the system's own, often two hours)."""
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
    for name, value in (
        ("TCP_KEEPIDLE", KEEPALIVE_IDLE),
        ("TCP_KEEPINTVL", KEEPALIVE_INTERVAL),
        ("TCP_KEEPCNT", KEEPALIVE_COUNT),
    ):
        option = getattr(socket, name, None)
        if option is not None:
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.IPPROTO_TCP, option, value)


class _TurnAway(Backend):
    """The backend of a connection past ``max_clients``: every request refused with the reason
    (flag 0x32, nothing done), KD answered with it."""

    def __init__(self, reason: str) -> None:
        self.reason = reason

    def handle(self, request: Request) -> None:
        if isinstance(request.command, ReadLastError):
            request.answer(request.session.last_error or self.reason)
            return
        raise Refusal(self.reason, FLAG_FAILED)

    def begin_upload(self, session: ControllerSession, command: UploadFile) -> None:
        raise Refusal(self.reason, FLAG_FAILED)


class _Connection(asyncio.Protocol):
    def __init__(self, owner: AsyncHost) -> None:
        self.owner = owner
        self.loop = asyncio.get_running_loop()
        self.transport: asyncio.Transport | None = None
        self.peer: BytePeer | None = None
        self.name = "?"
        self._timer: asyncio.TimerHandle | None = None
        self._scheduled = False
        self._idle_timer: asyncio.TimerHandle | None = None
        self._opened = self._last_activity = self.loop.time()
        self._turned_away = False
        self._early: bytearray | None = None
        """Bytes received while the connection's name is looked up (None: not looking)."""
        self._lookup: asyncio.Future[PeerOwner | None] | None = None
        self._lost = False

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
            reason = (
                f"{owner.name}: already {owner.max_clients} clients (the limit);"
                " nothing was done, try again later"
            )
            if len(owner.turned_away) >= owner.max_clients:
                log.warning("%s: refused %s: %s", owner.name, self.name, reason)
                transport.abort()
                return
            # A session that refuses every request, for a few seconds: the host program is
            # told its request was not done (flag 0x32, KD says why). Closing at once would
            # leave a host that already sent a request not knowing whether it ran.
            log.warning("%s: turning %s away: %s", owner.name, self.name, reason)
            self._turned_away = True
            self.peer = ControllerSession(_TurnAway(reason), name=self.name)
            self.peer.on_ready = self._soon
            owner.turned_away.add(self)
            self._socket_options(transport)
            self._idle_timer = self.loop.call_later(TURN_AWAY_IDLE, self._check_idle)
            return
        # The slot is held from now on, while the name is looked up too.
        owner.connections.add(self)
        self._socket_options(transport)
        if owner.idle_timeout is not None:
            self._idle_timer = self.loop.call_later(owner.idle_timeout, self._check_idle)
        # who is at the other end, for the log and the audit: the certificate's name, or the
        # local user and process of a peer on this machine (N1 itself carries no user name)
        common_name = _common_name(transport)
        due = lookup_due(address, common_name=common_name)
        if due is None:
            self._open(peer_name(address, common_name=common_name))
            return
        self._early = bytearray()
        self._lookup = self.loop.run_in_executor(_lookups(), peer_owner.find_owner, *due)
        self._lookup.add_done_callback(functools.partial(self._named, address))

    def _named(self, address: object, lookup: asyncio.Future[PeerOwner | None]) -> None:
        """The lookup ended: open the session under its name (unless the connection is gone)."""
        transport = self.transport
        if self._lost or transport is None or transport.is_closing():
            log.debug("%s: %s left before it was named", self.owner.name, self.name)
            return
        found: PeerOwner | None = None
        if not lookup.cancelled():
            try:
                found = lookup.result()
            except Exception:
                log.exception("%s: looking up who holds %s failed", self.owner.name, self.name)
        self._open(peer_name(address, owner=found))

    def _open(self, name: str) -> None:
        """Make the connection's session, named ``name``, and feed it what came meanwhile."""
        owner, transport = self.owner, self.transport
        assert transport is not None
        self.name = name
        early, self._early = self._early, None
        try:
            peer = owner.factory(name)
        except Exception:
            log.exception("%s: cannot open a session for %s", owner.name, name)
            transport.abort()
            return
        self.peer = peer
        if isinstance(peer, ControllerSession):
            peer.on_ready = self._soon
        log.info("%s: client %s connected", owner.name, name)
        if early is not None and len(early) >= NAMING_BUFFER:
            transport.resume_reading()
        if early:
            self._feed(bytes(early))

    @staticmethod
    def _socket_options(transport: asyncio.Transport) -> None:
        with contextlib.suppress(OSError, AttributeError):
            sock = transport.get_extra_info("socket")
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            _keepalive(sock)

    def _check_idle(self) -> None:
        """Close the connection when nothing moved for ``idle_timeout``; else look again then.
        (One timer per connection, moved at most once per period, not per byte.)"""
        self._idle_timer = None
        idle = TURN_AWAY_IDLE if self._turned_away else self.owner.idle_timeout
        transport = self.transport
        if idle is None or transport is None or transport.is_closing():
            return
        due = self._last_activity + idle
        if self._turned_away:
            due = min(due, self._opened + TURN_AWAY_MAX)
        if self.loop.time() < due:
            self._idle_timer = self.loop.call_at(due, self._check_idle)
            return
        if not self._turned_away:
            log.warning(
                "%s: closed %s: nothing sent or received for %g s (idle_timeout)",
                self.owner.name,
                self.name,
                idle,
            )
        transport.close()

    def data_received(self, data: bytes) -> None:
        early = self._early
        if early is not None:  # the session is not made yet: its name is being looked up
            self._last_activity = self.loop.time()
            early += data
            if len(early) >= NAMING_BUFFER and self.transport is not None:
                self.transport.pause_reading()
            return
        self._feed(data)

    def _feed(self, data: bytes) -> None:
        peer = self.peer
        if peer is None:
            return
        self._last_activity = self.loop.time()
        try:
            peer.feed(data, self.loop.time())
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
            out = peer.output(self.loop.time())
            deadline = peer.next_deadline()
        except Exception:
            self._fail()
            return
        if out:
            self._last_activity = self.loop.time()
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
        self._lost = True
        self._early = None
        if self._lookup is not None:
            self._lookup.cancel()  # a lookup still queued is not made
        if self._timer is not None:
            self._timer.cancel()
        if self._idle_timer is not None:
            self._idle_timer.cancel()
        self.owner.turned_away.discard(self)
        self.owner.connections.discard(self)
        if self.peer is not None and not self._turned_away:
            log.info("%s: client %s left", self.owner.name, self.name)
        if isinstance(self.peer, ControllerSession):
            self.peer.close()
        self.peer = None


class AsyncHost:
    """Serves one byte peer per TCP connection, made by ``factory(connection_name)``.

    ``await start(host, port)`` listens (loopback only unless ``allow_remote``) and returns the
    bound address; ``await close()`` stops listening and drops every connection.
    """

    def __init__(
        self,
        factory: Callable[[str], BytePeer],
        *,
        max_clients: int = MAX_CLIENTS,
        name: str = "n1",
        idle_timeout: float | None = IDLE_TIMEOUT,
    ) -> None:
        check_limits(max_clients, idle_timeout)
        self.factory = factory
        self.max_clients = max_clients
        self.idle_timeout = idle_timeout
        """Seconds a connection may be silent both ways before it is closed (None: never)."""
        self.name = name
        self.connections: set[_Connection] = set()
        self.turned_away: set[_Connection] = set()
        """Connections past ``max_clients``, refusing their requests until they are closed."""
        self.allow_from: tuple[Network, ...] | None = None
        self._server: asyncio.Server | None = None

    def admits(self, peername: object) -> bool:
        """Whether a peer at ``peername`` (a socket address) may be served."""
        return admits(self.allow_from, peername)

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
        for connection in [*self.connections, *self.turned_away]:
            connection._drop()
        # Aborted transports report connection_lost on the next loop turns.
        for _ in range(10):
            if not self.connections and not self.turned_away:
                break
            await asyncio.sleep(0)
        if server is not None:
            await server.wait_closed()

    async def __aenter__(self) -> AsyncHost:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()


def _common_name(transport: asyncio.BaseTransport) -> str | None:
    """The name a mutual-TLS peer's certificate gives: its common name, else its first e-mail
    or DNS name; None without a certificate."""
    cert = transport.get_extra_info("peercert")
    if not isinstance(cert, dict):
        return None
    for rdn in cert.get("subject", ()):
        for key, value in rdn:
            if key == "commonName":
                return str(value)
    for kind, value in cert.get("subjectAltName", ()):
        if kind in ("email", "DNS"):
            return str(value)
    return None
