"""A pytest plugin for programs that drive an N1: a simulated controller per test.

Installed with robostar (entry point ``pytest11``), so in a project that uses robostar these
fixtures are there without any import:

``n1_sim``
    A fresh simulated controller (:class:`N1Sim`) for the test: its model (positions, files,
    globals, alarms), what it executed, and a fault injector on its line.
``n1_client``
    A :class:`robostar.Client` connected to it (closed after the test).
``n1_async_client``
    A :class:`robostar.AsyncClient` connected to it (for async tests, e.g. with
    ``asyncio.run`` or pytest-asyncio).

Configure the controller with a marker, as ``sim://`` URLs do::

    @pytest.mark.n1_sim(channels=1, robot="xy", axes=2, dialect="capacity", speedup=50)
    def test_pick_and_place(n1_client, n1_sim): ...

A test makes the line or the robot misbehave with :meth:`N1Sim.fault` (the next exchange
meets a NAK, a dropped byte, a delay, ...) and :meth:`N1Sim.raise_alarm`. This module imports
the simulator only when a fixture is used, so a test run that uses none pays nothing for it.
"""

from __future__ import annotations

import asyncio
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from robostar.client import AsyncClient, Client
    from robostar.sim import VirtualController
    from robostar.sim.faults import FaultInjector

__all__ = ["N1Sim", "n1_async_client", "n1_client", "n1_sim"]

_MARKER = "n1_sim"
_DEFAULTS = {"speedup": "20", "seed": "1"}
"""Unless the marker says otherwise, model time runs 20 times faster (moves take milliseconds)
and random choices are repeatable."""


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        f"{_MARKER}(**options): configure the n1_sim fixture's simulated controller "
        "(channels, robot, axes, speedup, dialect, seed, ... as a sim:// URL's query; "
        "timeout= for the clients' reply timeout)",
    )


class N1Sim:
    """A simulated N1 for one test, with its line's fault injector.

    ``controller`` is the :class:`~robostar.sim.VirtualController` (``controller.model`` holds
    the state: ``model.channel(1).joints``, ``model.floats``, ...); ``faults`` is the
    :class:`~robostar.sim.faults.FaultInjector` between it and the clients.
    """

    def __init__(self, options: dict[str, Any]) -> None:
        from robostar.sim import SimConfig, VirtualController
        from robostar.sim.faults import FaultInjector

        options = dict(options)
        self.timeout = float(options.pop("timeout", 1.0))
        query = {**_DEFAULTS, **{key: _text(value) for key, value in options.items()}}
        self.controller: VirtualController = VirtualController(SimConfig.from_query(query))
        self.faults: FaultInjector = FaultInjector(self.controller, seed=1)

    @property
    def model(self) -> Any:
        """The controller's state (positions, files, globals, alarms, I/O)."""
        return self.controller.model

    @property
    def executions(self) -> dict[str, int]:
        """How often each state-changing command was carried out (``{"GW": 1, ...}``)."""
        return dict(self.controller.executions)

    def fault(self, spec: str) -> None:
        """Damage the line from the next exchange on: a ``--fault`` spec such as ``"nak"``
        (the next host packet answered with NAK), ``"drop:to_host@3"``, ``"delay:0.5"``,
        ``"latency:0.3"`` or ``"corrupt:0.01"`` (docs/simulator.md, Fault injection)."""
        self.faults.add(spec)

    def heal(self) -> None:
        """Remove every fault."""
        self.faults.clear()

    def raise_alarm(self, code: int, channel: int | None = None, detail: str = "") -> None:
        """Raise alarm ``code`` on a channel (all when None), as the controller would: the
        channel stops; an emergency turns the servo off."""
        from robostar.sim.alarms import ALL_CHANNELS

        self.model.raise_alarm(code, ALL_CHANNELS if channel is None else channel, detail)

    def transport(self) -> Any:
        from robostar.transport import PeerTransport

        return PeerTransport(self.faults)

    def async_transport(self) -> Any:
        from robostar.transport import AsyncPeerTransport

        return AsyncPeerTransport(self.faults)


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "enb" if value else "dis"
    if isinstance(value, list | tuple):
        return ",".join(str(v) for v in value)
    return str(value)


@pytest.fixture
def n1_sim(request: pytest.FixtureRequest) -> N1Sim:
    """A fresh simulated N1 controller (configure it with ``@pytest.mark.n1_sim(...)``)."""
    options: dict[str, Any] = {}
    for marker in reversed(list(request.node.iter_markers(_MARKER))):
        options.update(marker.kwargs)
    return N1Sim(options)


@pytest.fixture
def n1_client(n1_sim: N1Sim) -> Iterator[Client]:
    """A :class:`robostar.Client` connected to ``n1_sim``."""
    from robostar.client import Client

    client = Client(n1_sim.transport(), timeout=n1_sim.timeout, poll_interval=0.005)
    try:
        yield client
    finally:
        client.close()


@pytest.fixture
def n1_async_client(n1_sim: N1Sim) -> Iterator[AsyncClient]:
    """A :class:`robostar.AsyncClient` connected to ``n1_sim``; it connects on first use, in
    the test's event loop."""
    from robostar.client import AsyncClient

    client = AsyncClient(n1_sim.async_transport(), timeout=n1_sim.timeout, poll_interval=0.005)
    try:
        yield client
    finally:
        if client.transport.is_open:
            asyncio.run(_close(client))


async def _close(client: AsyncClient) -> None:
    await client.close()
