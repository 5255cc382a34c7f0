"""Serving the virtual controller over TCP and a pseudo-terminal, and :func:`serve`.

The threaded :class:`~robostar.sim.host.PeerHost` gives every TCP connection and the
pseudo-terminal an N1 session of its own on the controller (:class:`SimSessions` wraps each in the
fault injector and line timing). :class:`SimServer` serves on a TCP port, :class:`PtyServer` on
a pseudo-terminal; :func:`serve` builds whole simulators (controller, faults, line timing, state
directory) and runs them until interrupted.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Self

from robostar.controller_role.limits import MAX_CLIENTS
from robostar.controller_role.session import ControllerSession
from robostar.errors import UsageError
from robostar.listen import (
    DEFAULT_LISTEN,
    check_host,
    check_port,
    parse_listen,
    tcp_url,
    warn_remote,
)
from robostar.sim.controller import VirtualController
from robostar.sim.faults import FaultInjector, FaultSpec, parse_fault
from robostar.sim.host import PeerHost, SessionSource
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
    "SimSessions",
    "build_lines",
    "parse_listen",
    "serve",
]

log = logging.getLogger(__name__)

_REMOTE_POWERS = (
    "move the robot, start and stop jobs, write and delete its files and change its variables"
)


class SimSessions:
    """A session per connection on one controller, each inside its own fault injector (seeded
    ``seed``) when there are ``faults`` and inside line timing when ``baud`` is given."""

    def __init__(
        self,
        controller: VirtualController,
        *,
        faults: Sequence[FaultSpec] = (),
        seed: int | None = None,
        baud: int | None = None,
        turnaround: float = 0.0,
    ) -> None:
        self.controller = controller
        self.faults = list(faults)
        self.seed = seed
        self.baud = baud
        self.turnaround = turnaround
        self.paced = baud is not None
        if baud is not None:
            PacedPeer(controller, baud=baud, turnaround=turnaround)  # refuses bad values now
        self.injectors: list[FaultInjector] = []
        """Every session's fault injector, in the order the sessions opened."""
        self._sessions: dict[int, ControllerSession] = {}

    @property
    def executions(self) -> object:
        return self.controller.executions

    def open_session(self, name: str) -> BytePeer:
        session = self.controller.open_session(name)
        peer: BytePeer = session
        if self.faults:
            # The first session takes ``seed`` itself; later ones their own, still reproducible.
            seed = None if self.seed is None else self.seed + 7919 * len(self.injectors)
            injector = FaultInjector(peer, seed=seed)
            for spec in self.faults:
                injector.add(spec)
            self.injectors.append(injector)
            peer = injector
        if self.baud is not None:
            # Pacing outermost: what the injector adds (a NAK, an RST) takes wire time too.
            peer = PacedPeer(peer, baud=self.baud, turnaround=self.turnaround)
        self._sessions[id(peer)] = session
        return peer

    def close_session(self, peer: BytePeer) -> None:
        session = self._sessions.pop(id(peer), None)
        if session is not None:
            session.close()

    def poll(self, now: float) -> None:
        self.controller.poll(now)

    def shared_deadline(self) -> float | None:
        return self.controller.shared_deadline()


_JOIN_TIMEOUT = 10.0


class SimServer(PeerHost):
    """Serves on ``host:port`` over TCP (port 0 picks a free port): a session per connection
    for a :class:`SessionSource` (a :class:`VirtualController`), else one shared byte peer.

    Only loopback addresses are served unless ``allow_remote`` is True. :attr:`address` and
    :attr:`url` are known once started.
    """

    def __init__(
        self,
        peer: SessionSource | BytePeer,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        allow_remote: bool = False,
        name: str = "sim",
        max_clients: int = MAX_CLIENTS,
    ) -> None:
        check_host(host, allow_remote)
        check_port(port)
        super().__init__(peer, name=name, max_clients=max_clients)
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
        return tcp_url(host, port)


class PtyServer(PeerHost):
    """Serves one line (one session) on a pseudo-terminal; open :attr:`device_path` like a
    serial port."""

    def __init__(self, peer: SessionSource | BytePeer, *, name: str = "sim") -> None:
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


def _say_version(config: SimConfig) -> None:
    """Said, not silently done: whoever configured a robot's version learns why AD differs."""
    note = (
        f"the simulator answers AD with version {config.served_version!r}, not "
        f"{config.version!r}: a simulator's version always ends in -SIM, so that no console "
        "takes it for a robot (docs/simulator.md, Configuration)"
    )
    log.info("%s", note)
    print(f"note: {note}", file=sys.stderr, flush=True)


def build_lines(
    config: SimConfig,
    index: int = 0,
    *,
    store: StateStore | None = None,
    faults: Sequence[FaultSpec] = (),
    baud: int | None = None,
    turnaround: float = 0.0,
) -> SimSessions:
    """Simulated controller ``index`` as :func:`serve` runs it: a virtual controller whose
    sessions run inside a fault injector when there are ``faults`` (seeded from
    ``config.seed + index``) and inside line timing when ``baud`` is given."""
    seed = None if config.seed is None else config.seed + index
    return SimSessions(
        VirtualController(config, store=store),
        faults=faults,
        seed=seed,
        baud=baud,
        turnaround=turnaround,
    )


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
    max_clients: int = MAX_CLIENTS,
) -> None:
    """Serve ``count`` virtual controllers until Ctrl-C, SIGTERM or ``stop`` is set.

    Controller N listens on ``listen``'s port + N - 1 (each takes a free port if it is 0) and,
    with ``pty``, on a pseudo-terminal of its own. ``state_dir`` keeps the state across runs
    (``state_dir/ctrl-N`` for each when ``count`` > 1). ``faults`` are ``--fault`` specs;
    ``baud`` (or a ``turnaround`` alone, at 115200 baud) turns line timing on. ``control``
    (a loopback ``HOST:PORT``) opens the control socket of :mod:`robostar.sim.control`. The
    endpoints (``tcp://...`` URLs, device paths, ``control://...``) go to ``on_ready`` once all
    are up, else to stdout. Each TCP connection is an N1 session of its own, at most
    ``max_clients`` at once per controller; a non-loopback address (``allow_remote``) is
    announced on stderr and in the log, and so is a configured version that AD serves with the
    simulator's ``-SIM`` mark added (:attr:`SimConfig.served_version`).
    """
    from robostar.sim.config import SimConfig

    if config is None:
        config = SimConfig()
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise UsageError(f"count: {count!r} is not 1 or more")
    if config.served_version != config.version:
        _say_version(config)
    if listen is None and not pty:
        raise UsageError("listen: nothing to serve; give an address to listen on or pty=True")
    address = parse_listen(listen) if listen is not None else None
    if address is not None:
        check_host(address[0], allow_remote)
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
            lines = build_lines(
                config, i, store=stores[i], faults=specs, baud=baud, turnaround=turnaround
            )
            host = PeerHost(lines, name=f"ctrl-{i + 1}", max_clients=max_clients)
            hosts.append(host)
            if address is not None:
                port = address[1] + i if address[1] else 0
                bound = host.listen_tcp(address[0], port, allow_remote=allow_remote)
                warn_remote(bound[0], bound[1], f"{_REMOTE_POWERS} of simulated controller {i + 1}")
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
