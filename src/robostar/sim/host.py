"""The threaded host: byte peers on a thread of their own, over TCP clients and a pseudo-terminal.

:class:`PeerHost` runs on one thread, driven by ``time.monotonic()`` and woken by the peers'
``next_deadline()``. Given a :class:`SessionSource` (the simulator's controller), every TCP
connection and the pseudo-terminal get a session of their own, so each answer goes to the
connection that asked; an exception in one session drops that connection with a log line and the
others go on. Given a plain byte peer, the host serves it as one shared line, as a controller's
serial line is: every stream's bytes go into the same peer, and the peer's bytes go to the stream
whose bytes were fed last. TCP connections past ``max_clients`` are refused with a log line; an
accept that fails for want of descriptors backs off instead of spinning.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import selectors
import socket
import struct
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from types import TracebackType
from typing import Protocol, Self, runtime_checkable

from robostar.controller_role.limits import MAX_CLIENTS, MAX_PENDING, MAX_PENDING_PTY
from robostar.errors import PortError, UsageError
from robostar.listen import check_host, check_port, tcp_url
from robostar.protocol.frame import NAK, RST, FrameTracker
from robostar.transport.peer import BytePeer

__all__ = ["PeerHost", "SessionSource"]

log = logging.getLogger(__name__)

_READ_SIZE = 4096
_IDLE_WAKE = 0.2
"""The loop looks at the peer at least this often, for changes made from other threads."""
_MIN_WAIT = 0.0002
"""Shortest sleep, so a peer whose deadline does not move cannot make the loop spin."""
_SPIN = 0.0003
"""A paced line polls without sleeping for the last this-many seconds before a deadline."""
_SPIN_GRACE = 0.001
"""How long a paced line may poll past a deadline that does not move before it sleeps again."""
_SO_TIMESTAMPNS = 35
"""Linux's SO_TIMESTAMPNS (SCM_TIMESTAMPNS), which Python's socket module does not name: the
kernel stamps each received packet with the (real) time it arrived."""
_STAMP_SPACE = socket.CMSG_SPACE(16) if hasattr(socket, "CMSG_SPACE") else 0


def _ask_for_stamps(sock: socket.socket) -> bool:
    """Ask the kernel to stamp what ``sock`` receives (Linux); False where it cannot."""
    if not sys.platform.startswith("linux") or not _STAMP_SPACE:
        return False
    try:
        sock.setsockopt(socket.SOL_SOCKET, _SO_TIMESTAMPNS, 1)
    except OSError:
        return False
    return True


def _arrival(ancillary: list[tuple[int, int, bytes]]) -> float | None:
    """The monotonic time a read's bytes arrived, from the kernel's stamp (None if absent or
    not believable: later than now, or more than a second ago)."""
    for level, kind, data in ancillary:
        if level == socket.SOL_SOCKET and kind == _SO_TIMESTAMPNS and len(data) >= 16:
            seconds, nanoseconds = struct.unpack("qq", data[:16])
            now_wall, now = time.time(), time.monotonic()
            arrived = now - (now_wall - (seconds + nanoseconds * 1e-9))
            return arrived if now - 1.0 < arrived <= now else None
    return None


_JOIN_TIMEOUT = 10.0
_ACCEPT_BACKOFF = 0.5
"""Seconds the listeners rest after an accept failed for want of descriptors or memory."""
_ACCEPT_RESOURCE_ERRORS = frozenset((errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM))


@runtime_checkable
class SessionSource(Protocol):
    """Makes one byte peer (a session, maybe wrapped) per connection on shared state."""

    paced: bool
    """The sessions keep line timing (the host then sleeps with microsecond timeouts)."""

    def open_session(self, name: str) -> BytePeer:
        """A new session for the connection ``name``."""

    def close_session(self, peer: BytePeer) -> None:
        """The connection of ``peer`` (from :meth:`open_session`) is gone."""

    def poll(self, now: float) -> None:
        """Advance the shared state to ``now`` (before the sessions are asked for bytes)."""

    def shared_deadline(self) -> float | None:
        """When :meth:`poll` must be called again even if no connection does anything."""


def _take_disconnect(peer: object) -> bool:
    """Whether a fault injector anywhere in the chain of wrapped peers cut the line."""
    return any(take() for take in _disconnect_takers(peer))


def _disconnect_takers(peer: object) -> tuple[Callable[[], bool], ...]:
    """The ``take_disconnect`` of every peer in the chain of wrapped peers (the chain is set
    when the line opens, so a line asks once)."""
    takers = []
    for _ in range(16):
        take = getattr(peer, "take_disconnect", None)
        if callable(take):
            takers.append(take)
        peer = getattr(peer, "peer", None)
        if peer is None:
            break
    return tuple(takers)


_PacketTail = FrameTracker
"""Where the bytes fed to the peer stand in a packet, to finish a half-sent one.

A client that disconnects in the middle of a packet would leave the controller's decoder inside
it, and the next client's request would reach it as a damaged packet. The host then closes the
fragment as a corrupt packet (:meth:`FrameTracker.closing_bytes`: ETX and a wrong LRC) and hides
the controller's NAK, so the next client starts on a clean line."""


class _Stream:
    """One byte stream to a host program: a TCP client or the pseudo-terminal's master side."""

    kind = "stream"
    max_pending = MAX_PENDING

    def __init__(self, name: str) -> None:
        self.name = name
        self.out = bytearray()
        self.writing = False
        """Registered for EVENT_WRITE too (bytes wait in :attr:`out`)."""
        self.arrived: float | None = None
        """``time.monotonic()`` at which the kernel received the last read's bytes, where the
        stream knows it (a stamped TCP stream of a paced line): the line's wire time counts
        from then, not from whenever this thread woke to read them."""

    def fileno(self) -> int:
        raise NotImplementedError

    def read(self) -> bytes | None:
        """Bytes read; None if none are ready; b"" when the other end has gone."""
        raise NotImplementedError

    def send(self, data: bytes) -> int:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError


class _TcpStream(_Stream):
    kind = "tcp"

    def __init__(self, sock: socket.socket, name: str, *, stamped: bool = False) -> None:
        super().__init__(name)
        self.sock = sock
        self.stamped = stamped and _ask_for_stamps(sock)

    def fileno(self) -> int:
        return self.sock.fileno()

    def read(self) -> bytes | None:
        try:
            if not self.stamped:
                return self.sock.recv(_READ_SIZE)
            data, ancillary, _, _ = self.sock.recvmsg(_READ_SIZE, _STAMP_SPACE)
        except (BlockingIOError, InterruptedError):
            return None
        except OSError:
            return b""
        self.arrived = _arrival(ancillary)
        return data

    def send(self, data: bytes) -> int:
        return self.sock.send(data)

    def close(self) -> None:
        self.sock.close()


class _PtyStream(_Stream):
    kind = "pty"
    max_pending = MAX_PENDING_PTY

    def __init__(self) -> None:
        import tty

        master, slave = os.openpty()
        # Raw mode: no echo, no line editing, no CR/LF translation; the protocol is binary.
        tty.setraw(master)
        tty.setraw(slave)
        os.set_blocking(master, False)
        self.master = master
        # Keeping the slave side open means reads on the master never fail with EIO while no
        # program has the device open, and the terminal keeps its raw settings between openers.
        self.slave = slave
        self.device_path = os.ttyname(slave)
        super().__init__(self.device_path)

    def fileno(self) -> int:
        return self.master

    def read(self) -> bytes | None:
        try:
            return os.read(self.master, _READ_SIZE) or None
        except (BlockingIOError, InterruptedError):
            return None
        except OSError as exc:
            if exc.errno == errno.EIO:
                return None
            raise

    def send(self, data: bytes) -> int:
        return os.write(self.master, data)

    def close(self) -> None:
        for fd in (self.master, self.slave):
            with contextlib.suppress(OSError):
                os.close(fd)


@dataclass(eq=False)
class _PeerStreams:
    """A byte peer and the streams it serves (one for a session, any number when shared)."""

    peer: BytePeer
    owned: bool
    """A session from the source: closed with its stream, and its failure drops only it."""
    streams: list[_Stream] = field(default_factory=list)
    current: _Stream | None = None
    tail: _PacketTail = field(default_factory=lambda: _PacketTail())
    hide_reaction: bool = False
    takers: tuple[Callable[[], bool], ...] | None = None
    """The peer chain's ``take_disconnect`` methods, found on first use."""


class PeerHost:
    """Runs byte peers on a thread and connects them to TCP clients and a pseudo-terminal.

    ``source`` is a :class:`SessionSource` (a session per connection) or one byte peer (one
    shared line). Add endpoints with :meth:`listen_tcp` and :meth:`open_pty` before
    :meth:`start`. Every call into a peer is made holding :attr:`lock`; hold it too when touching
    the peer from another thread (test hooks such as ``controller.model.set_input``). If the
    shared state (or a shared line's peer) raises, the thread stops, closes every connection and
    keeps the exception in :attr:`failure`.
    """

    def __init__(
        self,
        source: SessionSource | BytePeer,
        *,
        name: str = "sim",
        max_clients: int = MAX_CLIENTS,
    ) -> None:
        if isinstance(source, SessionSource):
            self.source: SessionSource | None = source
            self._shared: _PeerStreams | None = None
        elif isinstance(source, BytePeer):
            self.source = None
            self._shared = _PeerStreams(source, owned=False)
        else:
            raise UsageError(f"peer: {type(source).__name__} is not a BytePeer or SessionSource")
        if isinstance(max_clients, bool) or not isinstance(max_clients, int) or max_clients < 1:
            raise UsageError(f"max_clients: {max_clients!r} is not 1 or more")
        self.peer = source
        self.name = name
        self.max_clients = max_clients
        self.lock = threading.RLock()
        self.endpoints: list[str] = []
        """What hosts can connect to: ``tcp://host:port`` URLs and pseudo-terminal paths."""
        self.failure: BaseException | None = None
        # A paced line waits in select(), whose timeouts are in microseconds: epoll rounds up
        # to whole milliseconds, which would make paced answers leave late. Unpaced hosts keep
        # epoll (select() cannot take descriptors past 1024, and --count serves many).
        self._paced = bool(getattr(source, "paced", False))
        self._selector: selectors.BaseSelector = (
            selectors.SelectSelector() if self._paced else selectors.DefaultSelector()
        )
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._selector.register(self._wake_r, selectors.EVENT_READ, self._on_wake)
        self._listeners: list[socket.socket] = []
        self._lines: list[_PeerStreams] = [] if self._shared is None else [self._shared]
        self._line_of: dict[_Stream, _PeerStreams] = {}
        self._accept_paused_until: float | None = None
        self._accept_error_logged = False
        self.accept_failures = 0
        """Accepts that failed for want of descriptors or memory (each is followed by a rest)."""
        self._stop = False
        self._thread: threading.Thread | None = None
        self._closed = False

    # -- setting up ----------------------------------------------------------------------------
    def _check_not_started(self, what: str) -> None:
        if self._thread is not None or self._closed:
            raise UsageError(f"{what}: add endpoints before start()")

    def listen_tcp(
        self, host: str = "127.0.0.1", port: int = 0, *, allow_remote: bool = False
    ) -> tuple[str, int]:
        """Listen on ``host:port`` (port 0 picks a free one); returns the bound address."""
        self._check_not_started("listen_tcp")
        check_host(host, allow_remote)
        check_port(port)
        try:
            family, kind, proto, _, address = socket.getaddrinfo(
                host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE
            )[0]
            sock = socket.socket(family, kind, proto)
        except OSError as exc:
            raise PortError(f"listen {host}:{port}: {exc}") from exc
        try:
            if os.name == "posix":
                # Lets a restarted simulator take its port back while old connections linger.
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind(address)
            sock.listen(8)
            sock.setblocking(False)
            if self._paced:
                # The kernel turns receive stamps on lazily (deferred work): asked for only when
                # a host connects, its first packets may come unstamped. Asked for here, they are
                # on before anyone connects (accepted sockets inherit the option).
                _ask_for_stamps(sock)
        except OSError as exc:
            sock.close()
            reason = exc.strerror or str(exc)
            raise PortError(f"listen {host}:{port}: {reason}") from exc
        bound = sock.getsockname()
        self._listeners.append(sock)
        self._selector.register(sock, selectors.EVENT_READ, lambda mask, s=sock: self._accept(s))
        self.endpoints.append(tcp_url(bound[0], bound[1]))
        return str(bound[0]), int(bound[1])

    def open_pty(self) -> str:
        """Open a pseudo-terminal pair and serve on it; returns the device path to open."""
        self._check_not_started("open_pty")
        if os.name != "posix":
            raise PortError("pty: pseudo-terminals need a POSIX system")
        try:
            stream = _PtyStream()
        except OSError as exc:
            raise PortError(f"pty: cannot open a pseudo-terminal: {exc}") from exc
        self._add_stream(stream)
        self.endpoints.append(stream.device_path)
        return stream.device_path

    # -- lifetime ------------------------------------------------------------------------------
    def start(self) -> Self:
        """Start serving on a daemon thread."""
        self._check_not_started("start")
        self._thread = threading.Thread(target=self._run, name=f"robostar-{self.name}", daemon=True)
        self._thread.start()
        return self

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @property
    def clients(self) -> int:
        """TCP clients connected now."""
        return sum(1 for stream in list(self._line_of) if stream.kind == "tcp")

    def close(self) -> None:
        """Stop serving and close every socket and the pseudo-terminal."""
        if self._closed:
            return
        self._closed = True
        self._stop = True
        thread = self._thread
        if thread is not None:
            self.wake()
            thread.join(_JOIN_TIMEOUT)
        if thread is None or not thread.is_alive():
            self._release()

    def wake(self) -> None:
        """Make the serving thread look at the peers now (after a change from another thread)."""
        with contextlib.suppress(OSError):
            self._wake_w.send(b"\0")

    def __enter__(self) -> Self:
        if self._thread is None:
            self.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- the loop ------------------------------------------------------------------------------
    def _run(self) -> None:
        try:
            while not self._stop:
                for key, mask in self._selector.select(self._wait_time()):
                    key.data(mask)
                    if self._stop:
                        break
                self._resume_accepting()
                self._pump()
        except BaseException as exc:
            self.failure = exc
            log.exception("simulator %s stopped", self.name)
        finally:
            self._drop_all()

    def _wait_time(self) -> float:
        with self.lock:
            times = [line.peer.next_deadline() for line in self._lines]
            if self.source is not None:
                times.append(self.source.shared_deadline())
        if self._accept_paused_until is not None:
            times.append(self._accept_paused_until)
        deadline = min((t for t in times if t is not None), default=None)
        if deadline is None:
            return _IDLE_WAKE
        wait = deadline - time.monotonic()
        if self._paced and -_SPIN_GRACE < wait <= _SPIN:
            # A paced line's bytes are due to the microsecond, and a sleep ends late by tens of
            # them: sleep to just before, then poll until the moment. A deadline that stays in
            # the past (served, yet not moved) falls back to the shortest sleep below.
            return 0.0
        if self._paced and wait > _SPIN:
            return min(wait - _SPIN, _IDLE_WAKE)
        return min(max(wait, _MIN_WAIT), _IDLE_WAKE)

    def _on_wake(self, mask: int) -> None:
        with contextlib.suppress(OSError):
            while self._wake_r.recv(_READ_SIZE):
                pass

    def _accept(self, listener: socket.socket) -> None:
        try:
            sock, address = listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            if exc.errno in _ACCEPT_RESOURCE_ERRORS:
                self._pause_accepting(exc)
            else:
                log.warning("simulator %s: accept failed", self.name, exc_info=True)
            return
        self._accept_error_logged = False
        name = f"{address[0]}:{address[1]}" if isinstance(address, tuple) else str(address)
        if self.clients >= self.max_clients:
            log.warning(
                "simulator %s: refused %s: already %d clients (the limit)",
                self.name,
                name,
                self.max_clients,
            )
            sock.close()
            return
        sock.setblocking(False)
        if sock.family in (socket.AF_INET, socket.AF_INET6):
            # Answers are a few bytes; do not hold them back waiting for more (Nagle).
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        stream = _TcpStream(sock, name, stamped=self._paced)
        log.info("simulator %s: client %s connected", self.name, stream.name)
        self._add_stream(stream)

    def _pause_accepting(self, exc: OSError) -> None:
        """Out of descriptors: rest the listeners a while (the connection waits in the
        backlog) instead of waking at once for the same failure; say so once."""
        self.accept_failures += 1
        if not self._accept_error_logged:
            self._accept_error_logged = True
            log.warning(
                "simulator %s: cannot accept (%s); retrying every %.1f s",
                self.name,
                exc.strerror or exc,
                _ACCEPT_BACKOFF,
            )
        self._accept_paused_until = time.monotonic() + _ACCEPT_BACKOFF
        for sock in self._listeners:
            with contextlib.suppress(KeyError, ValueError):
                self._selector.unregister(sock)

    def _resume_accepting(self) -> None:
        until = self._accept_paused_until
        if until is None or time.monotonic() < until:
            return
        self._accept_paused_until = None
        for sock in self._listeners:
            self._selector.register(
                sock, selectors.EVENT_READ, lambda mask, s=sock: self._accept(s)
            )

    def _add_stream(self, stream: _Stream) -> None:
        if self._shared is not None:
            line = self._shared
        else:
            assert self.source is not None
            with self.lock:
                line = _PeerStreams(self.source.open_session(stream.name), owned=True)
            self._lines.append(line)
        line.streams.append(stream)
        self._line_of[stream] = line
        self._selector.register(
            stream.fileno(), selectors.EVENT_READ, lambda mask, s=stream: self._on_stream(s, mask)
        )

    def _on_stream(self, stream: _Stream, mask: int) -> None:
        line = self._line_of.get(stream)
        if line is None:
            return
        if mask & selectors.EVENT_READ:
            data = stream.read()
            if data == b"":
                log.info("simulator %s: client %s left", self.name, stream.name)
                self._drop(stream)
                return
            if data:
                now = time.monotonic()
                # a paced line counts the bytes' wire time from their arrival, as a UART would
                at = stream.arrived if stream.arrived is not None else now
                with self.lock:
                    if self.source is not None:
                        self.source.poll(now)
                    if not self._guard(line, line.peer.feed, data, at):
                        return
                line.current = stream
                line.tail.feed(data)
                if not line.owned:
                    # A shared line answers the stream that wrote last: answer this one now.
                    # A session's own line is pumped once this pass's events are handled
                    # (PeerHost._run), not twice.
                    self._pump_line(line)
        if mask & selectors.EVENT_WRITE:
            self._flush(stream)

    def _guard(self, line: _PeerStreams, call: object, *args: object) -> bool:
        """Call into a line's peer; a session that raises is dropped (False), alone."""
        assert callable(call)
        try:
            call(*args)
        except Exception:
            if not line.owned:
                raise
            names = ", ".join(s.name for s in line.streams)
            log.exception("simulator %s: session of %s failed; dropped", self.name, names)
            for stream in list(line.streams):
                self._drop(stream)
            return False
        return True

    def _pump(self) -> None:
        """Advance the shared state, then hand every line's bytes to its stream."""
        if self.source is not None:
            with self.lock:
                self.source.poll(time.monotonic())
        for line in list(self._lines):
            self._pump_line(line)

    def _pump_line(self, line: _PeerStreams) -> None:
        """Hand the peer's bytes to the stream being answered; act on a cut line."""
        got: list[bytes] = []
        with self.lock:
            if not self._guard(line, lambda: got.append(line.peer.output(time.monotonic()))):
                return
            takers = line.takers
            if takers is None:
                takers = line.takers = _disconnect_takers(line.peer)
            cut = any(take() for take in takers) if takers else False
        out = got[0]
        if out and line.hide_reaction:
            line.hide_reaction = False
            if out[0] in (NAK, RST):
                out = out[1:]
        stream = line.current if line.current is not None else None
        if stream is None and line.owned and line.streams:
            stream = line.streams[0]
        if out and stream is not None:
            stream.out += out
            self._flush(stream)
        if cut and stream is not None and stream.kind == "tcp" and stream in self._line_of:
            log.info("simulator %s: fault cut the line to %s", self.name, stream.name)
            self._drop(stream)

    def _flush(self, stream: _Stream) -> None:
        if stream not in self._line_of:
            return
        try:
            while stream.out:
                sent = stream.send(bytes(stream.out))
                del stream.out[:sent]
        except (BlockingIOError, InterruptedError):
            pass
        except OSError:
            self._drop(stream)
            return
        if len(stream.out) > stream.max_pending:
            if stream.kind == "pty":
                stream.out.clear()
            else:
                log.warning("simulator %s: %s does not read; dropped", self.name, stream.name)
                self._drop(stream)
                return
        writing = bool(stream.out)
        if writing is not stream.writing:
            stream.writing = writing
            events = selectors.EVENT_READ | (selectors.EVENT_WRITE if writing else 0)
            key = self._selector.get_key(stream.fileno())
            self._selector.modify(stream.fileno(), events, key.data)

    def _drop(self, stream: _Stream) -> None:
        """Close one stream: its session ends; on a shared line, leave the line clean."""
        line = self._line_of.pop(stream, None)
        if line is None:
            return
        line.streams.remove(stream)
        with contextlib.suppress(KeyError, ValueError, OSError):
            self._selector.unregister(stream.fileno())
        with contextlib.suppress(OSError):
            stream.close()
        if line.owned:
            self._lines.remove(line)
            assert self.source is not None
            with self.lock:
                try:
                    self.source.close_session(line.peer)
                except Exception:
                    log.exception("simulator %s: closing the session failed", self.name)
            return
        if stream is line.current:
            line.current = None
            closing = line.tail.closing_bytes()
            line.tail.reset()
            if closing:
                with self.lock:
                    line.peer.feed(closing, time.monotonic())
                line.hide_reaction = True
                self._pump_line(line)

    def _drop_all(self) -> None:
        """Close every connection and listener (the loop has ended: clients must not hang)."""
        for stream in list(self._line_of):
            with contextlib.suppress(OSError):
                stream.close()
            line = self._line_of.pop(stream)
            if line.owned and self.source is not None:
                with contextlib.suppress(Exception):
                    self.source.close_session(line.peer)
        self._lines = [] if self._shared is None else [self._shared]
        if self._shared is not None:
            self._shared.streams.clear()
            self._shared.current = None
        for sock in self._listeners:
            with contextlib.suppress(OSError):
                sock.close()
        self._listeners.clear()

    def _release(self) -> None:
        self._drop_all()
        with contextlib.suppress(OSError):
            self._selector.close()
        for sock in (self._wake_r, self._wake_w):
            sock.close()
