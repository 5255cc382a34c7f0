"""Fixtures for the client tests: a simulator reached over every line, by both clients.

``robot`` is the contract fixture: a client (blocking, or the asyncio client behind a blocking
bridge) talking to a fresh :class:`~robostar.sim.VirtualController` in memory, over TCP to a
:class:`~robostar.sim.listeners.SimServer`, or through a pseudo-terminal served by
:class:`~robostar.sim.listeners.PtyServer` (the real serial path through pyserial).
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import os
import threading
from collections.abc import Callable, Coroutine, Iterator
from dataclasses import dataclass
from types import TracebackType
from typing import Any

import pytest

from robostar.client import AsyncClient, AsyncJog, Client
from robostar.sim import SimConfig, VirtualController
from robostar.sim.listeners import PeerHost, PtyServer, SimServer
from robostar.transport import AsyncPeerTransport, BytePeer, PeerTransport

from .jog_fakes import SimulatedClock, simulate_jog_clock

LINES = ["memory", "tcp", "pty"] if os.name == "posix" else ["memory", "tcp"]
LINES.append("serve")  # through the line server's N1 face, in front of the simulator
FLAVORS = ["sync", "async"]

# Model time runs fast so that moves and homing take milliseconds; timeouts stay short so that
# a lost answer costs little, but above the time a busy two-core machine needs to answer.
SPEEDUP = 200.0
TIMEOUT = 0.5
POLL = 0.005
SERVE_SPEEDUP = 40.0


def sim_config(**overrides: Any) -> SimConfig:
    return SimConfig(**{"speedup": SPEEDUP, "seed": 7, **overrides})


class AsyncBridge:
    """An AsyncClient driven from blocking code: its event loop runs in a thread.

    Every coroutine method becomes a blocking call, so the contract suite runs unchanged on
    both clients; ``jog`` becomes a blocking context manager around the AsyncJog.
    """

    def __init__(self, make: Callable[[], AsyncClient]) -> None:
        self.loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self._thread.start()

        async def build() -> AsyncClient:
            client = make()
            await client.connect()
            return client

        self.client = self.run(build())

    def run(self, coro: Coroutine[Any, Any, Any]) -> Any:
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout=60)

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self.client, name)
        if inspect.iscoroutinefunction(attr):
            return lambda *a, **k: self.run(attr(*a, **k))
        return attr

    def jog(self, *args: Any, **kwargs: Any) -> BridgedJog:
        return BridgedJog(self, self.client.jog(*args, **kwargs))

    def close(self) -> None:
        try:
            self.run(self.client.close())
        finally:
            self.loop.call_soon_threadsafe(self.loop.stop)
            self._thread.join(5)
            self.loop.close()


class BridgedJog:
    def __init__(self, bridge: AsyncBridge, jog: AsyncJog) -> None:
        self.bridge = bridge
        self.jog = jog

    @property
    def error(self) -> BaseException | None:
        return self.jog.error

    def __enter__(self) -> BridgedJog:
        self.bridge.run(self.jog.__aenter__())
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.bridge.run(self.jog.__aexit__(exc_type, exc, tb))


@dataclass
class Robot:
    """A client and the simulator it talks to."""

    client: Any  # Client or AsyncBridge: the same methods, blocking
    controller: VirtualController
    line: str
    flavor: str
    server: PeerHost | ServedLine | None

    def touch(self) -> contextlib.AbstractContextManager[Any]:
        """Hold while changing the simulator from the test (its server thread also uses it)."""
        return self.server.lock if self.server is not None else contextlib.nullcontext()


def open_client(
    line: str,
    flavor: str,
    peer: BytePeer,
    server: PeerHost | ServedLine | None,
    **options: Any,
) -> Any:
    """A client of ``flavor`` ("sync"/"async") on ``line`` to ``peer`` (served by ``server``)."""
    options = {"timeout": TIMEOUT, "poll_interval": POLL, **options}
    if line == "memory":
        if flavor == "sync":
            return Client(PeerTransport(peer), **options)
        return AsyncBridge(lambda: AsyncClient(AsyncPeerTransport(peer), **options))
    assert server is not None
    if isinstance(server, ServedLine):
        url = server.url
        if flavor == "sync":
            return Client(url, **options)
        return AsyncBridge(lambda: AsyncClient(url, **options))
    port = server.url if isinstance(server, SimServer) else server.device_path  # type: ignore[attr-defined]
    if flavor == "sync":
        return Client(port, **options)
    return AsyncBridge(lambda: AsyncClient(port, **options))


class ServedLine:
    """A line server (its own event loop in a thread) serving ``peer`` on its N1 face."""

    lock = threading.Lock()
    failure: BaseException | None = None

    def __init__(self, peer: BytePeer) -> None:
        from robostar.serve import LineConfig, LineServer, ServeConfig

        self.loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self._thread.start()
        config = ServeConfig(
            # One poll at start, and every read sent on: the contract counts the simulator's
            # requests and changes it behind the client's back (the model is tested in serve/).
            lines=(LineConfig("cell", "sim://", timeout=TIMEOUT, poll_interval=3600, max_age=0),),
            faces={"n1": {"lines": {"cell": "127.0.0.1:0"}}},
        )
        self.server = LineServer(
            config,
            client_factory=lambda lc: AsyncClient(AsyncPeerTransport(peer), timeout=lc.timeout),
        )
        asyncio.run_coroutine_threadsafe(self.server.start(), self.loop).result(30)
        line = self.server.lines["cell"]

        async def first_poll() -> None:
            while line.health.last_poll is None:
                await asyncio.sleep(0.005)

        asyncio.run_coroutine_threadsafe(first_poll(), self.loop).result(30)
        host, port = self.server.faces["n1"].addresses["cell"]  # type: ignore[attr-defined]
        self.url = f"tcp://{host}:{port}"

    def close(self) -> None:
        try:
            asyncio.run_coroutine_threadsafe(self.server.stop(), self.loop).result(30)
        finally:
            self.loop.call_soon_threadsafe(self.loop.stop)
            self._thread.join(5)
            self.loop.close()


def serve(line: str, peer: BytePeer) -> PeerHost | ServedLine | None:
    if line == "serve":
        return ServedLine(peer)
    if line == "tcp":
        return SimServer(peer).start()
    if line == "pty":
        return PtyServer(peer).start()
    return None


@contextlib.contextmanager
def robot_on(
    line: str,
    flavor: str,
    wrap: Callable[[VirtualController], BytePeer] | None = None,
    config: SimConfig | None = None,
    **options: Any,
) -> Iterator[Robot]:
    """A robot on ``line``; ``wrap`` puts a peer (a fault injector) between client and sim."""
    if config is None and line == "serve":
        # a hop more per exchange: model time slower, so a short job still runs when read back
        config = sim_config(speedup=SERVE_SPEEDUP)
    controller = VirtualController(config or sim_config())
    peer = wrap(controller) if wrap is not None else controller
    server = serve(line, peer)
    try:
        client = open_client(line, flavor, peer, server, **options)
        try:
            yield Robot(client, controller, line, flavor, server)
        finally:
            client.close()
    finally:
        if server is not None:
            server.close()
            assert server.failure is None, server.failure


@pytest.fixture(params=[(line, flavor) for line in LINES for flavor in FLAVORS], ids="-".join)
def robot(request: pytest.FixtureRequest) -> Iterator[Robot]:
    line, flavor = request.param
    with robot_on(line, flavor) as bot:
        yield bot


@pytest.fixture
def jog_clock(monkeypatch: pytest.MonkeyPatch) -> SimulatedClock:
    """The jog module's clock, simulated (see :func:`jog_fakes.simulate_jog_clock`)."""
    return simulate_jog_clock(monkeypatch)
