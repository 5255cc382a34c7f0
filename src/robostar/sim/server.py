"""Serving the virtual controller: byte peers over TCP and a pseudo-terminal, and :func:`serve`.

:class:`PeerHost` runs one byte peer on its own thread, driven by ``time.monotonic()`` and woken
by the peer's ``next_deadline()``, and connects it to any number of byte streams: TCP clients
and a pseudo-terminal. A controller has one line, so every stream's bytes go into the same peer,
and the peer's bytes go to the stream whose bytes were fed last (the one whose request is being
answered). :class:`SimServer` serves a peer on a TCP port, :class:`PtyServer` on a
pseudo-terminal; :func:`serve` builds whole simulators (controller, faults, line timing, state
directory) and runs them until interrupted.
"""

from __future__ import annotations

import contextlib
import errno
import ipaddress
import logging
import os
import selectors
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import FrameType, TracebackType
from typing import TYPE_CHECKING, Self

from robostar.errors import PortError, UsageError
from robostar.protocol.frame import ETX, NAK, RST, STX
from robostar.sim.faults import FaultInjector, FaultSpec, parse_fault
from robostar.sim.pacing import PacedPeer
from robostar.sim.store import StateStore
from robostar.transport.peer import BytePeer

if TYPE_CHECKING:
    from robostar.sim.config import SimConfig

__all__ = [
    "DEFAULT_LISTEN",
    "PeerHost",
    "PtyServer",
    "SimServer",
    "build_peer",
    "parse_listen",
    "serve",
]

DEFAULT_LISTEN = "127.0.0.1:9100"

log = logging.getLogger(__name__)

_READ_SIZE = 4096
_MAX_PENDING_TCP = 1 << 20
"""A TCP client that leaves this much unread is dropped, so it cannot stall the controller."""
_MAX_PENDING_PTY = 1 << 16
"""Bytes for a pseudo-terminal nobody reads are thrown away past this, as on an unplugged line."""
_IDLE_WAKE = 0.2
"""The loop looks at the peer at least this often, for changes made from other threads."""
_MIN_WAIT = 0.0002
"""Shortest sleep, so a peer whose deadline does not move cannot make the loop spin."""
_JOIN_TIMEOUT = 10.0


def _is_loopback(host: str) -> bool:
    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except socket.gaierror:
        return False
    addresses = {info[4][0] for info in infos}
    return bool(addresses) and all(
        ipaddress.ip_address(str(a).split("%")[0]).is_loopback for a in addresses
    )


def _check_host(host: str, allow_remote: bool) -> None:
    if not isinstance(host, str) or not host:
        raise UsageError(f"host: {host!r} is not a host name or address")
    if not allow_remote and not _is_loopback(host):
        raise UsageError(
            f"host: {host!r} is not a loopback address; the simulator serves only this machine "
            "unless allow_remote=True (--allow-remote)"
        )


def _check_port(port: int) -> None:
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise UsageError(f"port: {port!r} is not 0..65535 (0 picks a free port)")


def parse_listen(text: str) -> tuple[str, int]:
    """``"HOST:PORT"``, ``"[v6addr]:PORT"`` or a bare ``"PORT"`` (on 127.0.0.1)."""
    text = text.strip()
    if text.isdigit():
        host, port_text = "127.0.0.1", text
    elif text.startswith("["):
        inside, sep, port_text = text[1:].partition("]:")
        host = inside
        if not sep:
            raise UsageError(f"listen: {text!r} is not [ADDRESS]:PORT")
    else:
        host, sep, port_text = text.rpartition(":")
        if not sep or not host:
            raise UsageError(f"listen: {text!r} is not HOST:PORT (e.g. {DEFAULT_LISTEN})")
    if not port_text.isdigit():
        raise UsageError(f"listen: {port_text!r} in {text!r} is not a port number")
    port = int(port_text)
    _check_port(port)
    return host, port


def _tcp_url(host: str, port: int) -> str:
    return f"tcp://[{host}]:{port}" if ":" in host else f"tcp://{host}:{port}"


def _take_disconnect(peer: object) -> bool:
    """Whether a fault injector anywhere in the chain of wrapped peers cut the line."""
    for _ in range(16):
        take = getattr(peer, "take_disconnect", None)
        if callable(take) and take():
            return True
        peer = getattr(peer, "peer", None)
        if peer is None:
            break
    return False


class _LineTail:
    """Where the bytes fed to the peer stand in a packet, to finish a half-sent one.

    A client that disconnects in the middle of a packet would leave the controller's decoder
    inside it, and the next client's request would reach it as a damaged packet. The host then
    closes the fragment as a corrupt packet (ETX and a wrong LRC) and hides the controller's
    NAK, so the next client starts on a clean line.
    """

    __slots__ = ("in_lrc", "in_packet", "xor")

    def __init__(self) -> None:
        self.in_packet = False
        self.in_lrc = False
        self.xor = 0

    def feed(self, data: bytes) -> None:
        for byte in data:
            if self.in_lrc:
                self.in_lrc = False
            elif byte == STX:
                self.in_packet = True
                self.xor = 0
            elif self.in_packet and byte == ETX:
                self.in_packet = False
                self.in_lrc = True
            elif self.in_packet:
                self.xor ^= byte

    def closing_bytes(self) -> bytes:
        """Bytes that end the current fragment as a corrupt packet (empty between packets)."""
        wrong = self.xor ^ 0xFF  # never the LRC, nor the ETX taken for a zero LRC
        if self.in_packet:
            return bytes((ETX, wrong))
        if self.in_lrc:
            return bytes((wrong,))
        return b""

    def reset(self) -> None:
        self.in_packet = self.in_lrc = False
        self.xor = 0


class _Stream:
    """One byte stream to a host program: a TCP client or the pseudo-terminal's master side."""

    kind = "stream"
    max_pending = _MAX_PENDING_TCP

    def __init__(self, name: str) -> None:
        self.name = name
        self.out = bytearray()

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

    def __init__(self, sock: socket.socket, name: str) -> None:
        super().__init__(name)
        self.sock = sock

    def fileno(self) -> int:
        return self.sock.fileno()

    def read(self) -> bytes | None:
        try:
            return self.sock.recv(_READ_SIZE)
        except (BlockingIOError, InterruptedError):
            return None
        except OSError:
            return b""

    def send(self, data: bytes) -> int:
        return self.sock.send(data)

    def close(self) -> None:
        self.sock.close()


class _PtyStream(_Stream):
    kind = "pty"
    max_pending = _MAX_PENDING_PTY

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


class PeerHost:
    """Runs one byte peer on a thread and connects it to TCP clients and a pseudo-terminal.

    Add endpoints with :meth:`listen_tcp` and :meth:`open_pty` before :meth:`start`. Every call
    into the peer is made holding :attr:`lock`; hold it too when touching the peer from another
    thread (test hooks such as ``controller.model.set_input``). If the peer raises, the thread
    stops, closes every connection and keeps the exception in :attr:`failure`.
    """

    def __init__(self, peer: BytePeer, *, name: str = "sim") -> None:
        if not isinstance(peer, BytePeer):
            raise UsageError(f"peer: {type(peer).__name__} is not a BytePeer")
        self.peer = peer
        self.name = name
        self.lock = threading.RLock()
        self.endpoints: list[str] = []
        """What hosts can connect to: ``tcp://host:port`` URLs and pseudo-terminal paths."""
        self.failure: BaseException | None = None
        # A paced line waits in select(), whose timeouts are in microseconds: epoll rounds up
        # to whole milliseconds, which would make paced answers leave late. Unpaced hosts keep
        # epoll (select() cannot take descriptors past 1024, and --count serves many).
        self._selector: selectors.BaseSelector = (
            selectors.SelectSelector()
            if isinstance(peer, PacedPeer)
            else selectors.DefaultSelector()
        )
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._selector.register(self._wake_r, selectors.EVENT_READ, self._on_wake)
        self._listeners: list[socket.socket] = []
        self._streams: list[_Stream] = []
        self._current: _Stream | None = None
        self._tail = _LineTail()
        self._hide_reaction = False
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
        _check_host(host, allow_remote)
        _check_port(port)
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
        except OSError as exc:
            sock.close()
            reason = exc.strerror or str(exc)
            raise PortError(f"listen {host}:{port}: {reason}") from exc
        bound = sock.getsockname()
        self._listeners.append(sock)
        self._selector.register(sock, selectors.EVENT_READ, lambda mask, s=sock: self._accept(s))
        self.endpoints.append(_tcp_url(bound[0], bound[1]))
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
        return sum(1 for stream in list(self._streams) if stream.kind == "tcp")

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
        """Make the serving thread look at the peer now (after a change from another thread)."""
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
                self._pump()
        except BaseException as exc:
            self.failure = exc
            log.exception("simulator %s stopped", self.name)
        finally:
            self._drop_all()

    def _wait_time(self) -> float:
        with self.lock:
            deadline = self.peer.next_deadline()
        if deadline is None:
            return _IDLE_WAKE
        return min(max(deadline - time.monotonic(), _MIN_WAIT), _IDLE_WAKE)

    def _on_wake(self, mask: int) -> None:
        with contextlib.suppress(OSError):
            while self._wake_r.recv(_READ_SIZE):
                pass

    def _accept(self, listener: socket.socket) -> None:
        try:
            sock, address = listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            log.warning("simulator %s: accept failed", self.name, exc_info=True)
            return
        sock.setblocking(False)
        if sock.family in (socket.AF_INET, socket.AF_INET6):
            # Answers are a few bytes; do not hold them back waiting for more (Nagle).
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        stream = _TcpStream(sock, f"{address[0]}:{address[1]}")
        log.info("simulator %s: client %s connected", self.name, stream.name)
        self._add_stream(stream)

    def _add_stream(self, stream: _Stream) -> None:
        self._streams.append(stream)
        self._selector.register(
            stream.fileno(), selectors.EVENT_READ, lambda mask, s=stream: self._on_stream(s, mask)
        )

    def _on_stream(self, stream: _Stream, mask: int) -> None:
        if stream not in self._streams:
            return
        if mask & selectors.EVENT_READ:
            data = stream.read()
            if data == b"":
                log.info("simulator %s: client %s left", self.name, stream.name)
                self._drop(stream)
                return
            if data:
                with self.lock:
                    self.peer.receive_data(data, time.monotonic())
                self._current = stream
                self._tail.feed(data)
                self._pump()
        if mask & selectors.EVENT_WRITE:
            self._flush(stream)

    def _pump(self) -> None:
        """Hand the peer's bytes to the stream being answered; act on a cut line."""
        with self.lock:
            out = self.peer.data_to_send(time.monotonic())
            cut = _take_disconnect(self.peer)
        if out and self._hide_reaction:
            self._hide_reaction = False
            if out[0] in (NAK, RST):
                out = out[1:]
        stream = self._current
        if out and stream is not None:
            stream.out += out
            self._flush(stream)
        if cut and stream is not None and stream.kind == "tcp" and stream in self._streams:
            log.info("simulator %s: fault cut the line to %s", self.name, stream.name)
            self._drop(stream)

    def _flush(self, stream: _Stream) -> None:
        if stream not in self._streams:
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
        events = selectors.EVENT_READ | (selectors.EVENT_WRITE if stream.out else 0)
        self._selector.modify(stream.fileno(), events, self._selector.get_key(stream.fileno()).data)

    def _drop(self, stream: _Stream) -> None:
        """Close one stream; if it was being answered, leave the controller's line clean."""
        if stream not in self._streams:
            return
        self._streams.remove(stream)
        with contextlib.suppress(KeyError, ValueError, OSError):
            self._selector.unregister(stream.fileno())
        with contextlib.suppress(OSError):
            stream.close()
        if stream is self._current:
            self._current = None
            closing = self._tail.closing_bytes()
            self._tail.reset()
            if closing:
                with self.lock:
                    self.peer.receive_data(closing, time.monotonic())
                self._hide_reaction = True
                self._pump()

    def _drop_all(self) -> None:
        """Close every connection and listener (the loop has ended: clients must not hang)."""
        for stream in self._streams:
            with contextlib.suppress(OSError):
                stream.close()
        self._streams.clear()
        self._current = None
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


class SimServer(PeerHost):
    """Serves one byte peer on ``host:port`` over TCP (port 0 picks a free port).

    Only loopback addresses are served unless ``allow_remote`` is True. :attr:`address` and
    :attr:`url` are known once started.
    """

    def __init__(
        self,
        peer: BytePeer,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        allow_remote: bool = False,
        name: str = "sim",
    ) -> None:
        _check_host(host, allow_remote)
        _check_port(port)
        super().__init__(peer, name=name)
        self._host = host
        self._port = port
        self._allow_remote = allow_remote
        self._address: tuple[str, int] | None = None

    def start(self) -> Self:
        self._address = self.listen_tcp(self._host, self._port, allow_remote=self._allow_remote)
        return super().start()

    @property
    def address(self) -> tuple[str, int]:
        """The bound (host, port)."""
        if self._address is None:
            raise UsageError("address: the server is not started")
        return self._address

    @property
    def url(self) -> str:
        """``tcp://host:port``, as :func:`robostar.transport.open_transport` takes it."""
        host, port = self.address
        return _tcp_url(host, port)


class PtyServer(PeerHost):
    """Serves one byte peer on a pseudo-terminal; open :attr:`device_path` like a serial port."""

    def __init__(self, peer: BytePeer, *, name: str = "sim") -> None:
        super().__init__(peer, name=name)
        self._device: str | None = None

    def start(self) -> Self:
        self._device = self.open_pty()
        return super().start()

    @property
    def device_path(self) -> str:
        if self._device is None:
            raise UsageError("device_path: the server is not started")
        return self._device


def _print_endpoints(endpoints: list[str]) -> None:
    for endpoint in endpoints:
        print(endpoint, flush=True)


def build_peer(
    config: SimConfig,
    index: int = 0,
    *,
    store: StateStore | None = None,
    faults: Sequence[FaultSpec] = (),
    baud: int | None = None,
    turnaround: float = 0.0,
) -> BytePeer:
    """One simulated controller as :func:`serve` runs it: the virtual controller, inside a
    fault injector when there are ``faults`` (seeded ``config.seed + index``), inside line
    timing when ``baud`` is given."""
    from robostar.sim import VirtualController

    peer: BytePeer = VirtualController(config, store=store)
    if faults:
        seed = None if config.seed is None else config.seed + index
        injector = FaultInjector(peer, seed=seed)
        for spec in faults:
            injector.add(spec)
        peer = injector
    if baud is not None:
        # Pacing outermost: what the injector adds (a NAK, an RST) takes wire time too.
        peer = PacedPeer(peer, baud=baud, turnaround=turnaround)
    return peer


def serve(
    config: SimConfig | None = None,
    *,
    listen: str | None = DEFAULT_LISTEN,
    pty: bool = False,
    count: int = 1,
    state_dir: str | os.PathLike[str] | None = None,
    faults: Sequence[str] = (),
    baud: int | None = None,
    turnaround: float = 0.0,
    allow_remote: bool = False,
    on_ready: Callable[[list[str]], None] | None = None,
    stop: threading.Event | None = None,
    control: str | None = None,
) -> None:
    """Serve ``count`` virtual controllers until Ctrl-C, SIGTERM or ``stop`` is set.

    Controller N listens on ``listen``'s port + N - 1 (each takes a free port if it is 0) and,
    with ``pty``, on a pseudo-terminal of its own. ``state_dir`` keeps the state across runs
    (``state_dir/ctrl-N`` for each when ``count`` > 1). ``faults`` are ``--fault`` specs;
    ``baud`` (or a ``turnaround`` alone, at 115200 baud) turns line timing on. ``control``
    (a loopback ``HOST:PORT``) opens the control socket of :mod:`robostar.sim.control`. The
    endpoints (``tcp://...`` URLs, device paths, ``control://...``) go to ``on_ready`` once all
    are up, else to stdout.
    """
    from robostar.sim.config import SimConfig

    if config is None:
        config = SimConfig()
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise UsageError(f"count: {count!r} is not 1 or more")
    if listen is None and not pty:
        raise UsageError("listen: nothing to serve; give an address to listen on or pty=True")
    address = parse_listen(listen) if listen is not None else None
    if address is not None:
        _check_host(address[0], allow_remote)
        if address[1] and address[1] + count - 1 > 65535:
            raise UsageError(f"count: {count} ports from {address[1]} run past 65535")
    if isinstance(faults, str):
        raise UsageError("faults: give a list of fault specs, not one string")
    specs = [parse_fault(text) for text in faults]
    if baud is None and turnaround:
        baud = 115200
    stores: list[StateStore | None] = [None] * count
    if state_dir is not None:
        root = Path(state_dir)
        stores = [
            StateStore(root if count == 1 else root / f"ctrl-{i}") for i in range(1, count + 1)
        ]

    hosts: list[PeerHost] = []
    control_server = None
    stop = stop if stop is not None else threading.Event()
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGTERM) if in_main else None
    try:
        for i in range(count):
            peer = build_peer(
                config, i, store=stores[i], faults=specs, baud=baud, turnaround=turnaround
            )
            host = PeerHost(peer, name=f"ctrl-{i + 1}")
            hosts.append(host)
            if address is not None:
                port = address[1] + i if address[1] else 0
                host.listen_tcp(address[0], port, allow_remote=allow_remote)
            if pty:
                host.open_pty()
        for host in hosts:
            host.start()
        endpoints = [e for host in hosts for e in host.endpoints]
        if control is not None:
            from robostar.sim.control import ControlServer

            control_host, control_port = parse_listen(control)
            control_server = ControlServer(hosts, control_host, control_port).start()
            endpoints.append(control_server.endpoint)
        if in_main:

            def _on_term(signum: int, frame: FrameType | None) -> None:
                stop.set()

            signal.signal(signal.SIGTERM, _on_term)
        (on_ready or _print_endpoints)(endpoints)
        while not stop.wait(0.25):
            for host in hosts:
                if host.failure is not None:
                    raise host.failure
    except KeyboardInterrupt:
        pass
    finally:
        if control_server is not None:
            control_server.close()
        for host in hosts:
            host.close()
        if in_main and previous is not None:
            signal.signal(signal.SIGTERM, previous)
        sys.stdout.flush()
