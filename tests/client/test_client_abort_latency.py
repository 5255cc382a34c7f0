"""No answer of an abandoned exchange is ever taken for a later request's, at any latency.

The host abandons an exchange three ways: Ctrl-C in a blocking call (KeyboardInterrupt), a
cancelled asyncio task, and its own reply timeout. The abandoned read's answer is still on its
way, held by a serial device server with latency (0.05, 0.3 and 1.0 s each way); the next
read must return its own value, never the abandoned read's.

The line is real: the simulator over TCP behind a loopback relay that holds every chunk.
"""

from __future__ import annotations

import _thread
import asyncio
import threading
from collections.abc import Iterator

import pytest

from robostar import AsyncClient, Client
from robostar.errors import ReplyTimeoutError
from robostar.sim.config import SimConfig
from robostar.sim.controller import VirtualController
from robostar.sim.listeners import SimServer

from .delay_relay import DelayRelay

pytestmark = pytest.mark.timeout(120)

LATENCIES = [0.05, 0.3, pytest.param(1.0, marks=pytest.mark.slow)]
"""The 1 s line (a device server far away) takes ~10 s a case: in `make reliability`, not CI."""
G10, G20 = 1010, 2020
CANCEL_AFTER = 0.1
"""Seconds after a read's request went out that it is cancelled (its answer is coming)."""


def _timeout(latency: float) -> float:
    """A reply timeout over the round trip, as a client on such a line is given."""
    return max(1.0, 2 * latency + 0.5)


def _controller_timeout(latency: float) -> float:
    """The controller's own ACK timeout, set for the line: over the round trip of the
    slowest answer (a slow answer's ACK comes later still)."""
    return 3 * _timeout(latency)


@pytest.fixture(params=LATENCIES, ids=["0.05s", "0.3s", "1.0s"])
def relay(request: pytest.FixtureRequest) -> Iterator[DelayRelay]:
    controller = VirtualController(SimConfig(ack_timeout=_controller_timeout(request.param)))
    with SimServer(controller) as server:
        line = DelayRelay(server.address, request.param)
        yield line
        line.close()


def _hold_answers(relay: DelayRelay, abandon_at: float) -> None:
    """Hold answers on their way back so that the one to a request abandoned ``abandon_at`` s
    after it was sent arrives after the client's quiet gap (one reply timeout) and before the
    next request's answer: where only a check of what it answers can tell it is old."""
    relay.answer_delay = abandon_at + _timeout(relay.delay) - relay.delay


def _write_globals(client: Client) -> None:
    client.write_global_int(10, G10)
    client.write_global_int(20, G20)


def test_ctrl_c_in_a_blocking_read(relay: DelayRelay) -> None:
    with Client(
        relay.url,
        timeout=_timeout(relay.delay),
        controller_timeout=_controller_timeout(relay.delay),
    ) as client:
        _write_globals(client)
        for _ in range(1):
            _hold_answers(relay, CANCEL_AFTER)
            timer = threading.Timer(CANCEL_AFTER, _thread.interrupt_main)
            timer.start()
            with pytest.raises(KeyboardInterrupt):
                client.read_global_int(10)
                threading.Event().wait(10)  # the interrupt comes here if the read was quick
            timer.join()
            relay.answer_delay = 0.0
            assert client.read_global_int(20) == G20


def test_a_cancelled_task(relay: DelayRelay) -> None:
    async def run() -> list[int]:
        async with AsyncClient(
            relay.url,
            timeout=_timeout(relay.delay),
            controller_timeout=_controller_timeout(relay.delay),
        ) as client:
            await client.write_global_int(10, G10)
            await client.write_global_int(20, G20)
            values = []
            for _ in range(1):
                _hold_answers(relay, CANCEL_AFTER)
                task = asyncio.create_task(client.read_global_int(10))
                await asyncio.sleep(CANCEL_AFTER)
                task.cancel()
                with pytest.raises(asyncio.CancelledError):
                    await task
                relay.answer_delay = 0.0
                values.append(await client.read_global_int(20))
            return values

    assert asyncio.run(run()) == [G20]


def test_a_read_that_timed_out(relay: DelayRelay) -> None:
    # The controller is slow to answer one read, past the client's timeout; its answer is
    # still coming when the next read goes out.
    latency = relay.delay
    timeout = _timeout(latency)
    with Client(
        relay.url,
        timeout=timeout,
        retries=0,
        controller_timeout=_controller_timeout(latency),
    ) as client:
        _write_globals(client)
        for _ in range(1):
            _hold_answers(relay, timeout)
            with pytest.raises(ReplyTimeoutError):
                client.read_global_int(10)
            relay.answer_delay = 0.0
            assert client.read_global_int(20) == G20
