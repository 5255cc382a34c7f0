"""The jog's dead-man's switch (``held_until``): once the time it gives has passed, the keepalive
itself stops sending BF and sends BG, so a jog ends even when the code that should end it hangs
(the jog pad's screen write blocked by Ctrl-S). Without a switch a jog runs until stopped."""

from __future__ import annotations

import asyncio
import time

import pytest

from robostar.client import AsyncClient, Client
from robostar.client.jog import AsyncJog, Jog, jog_start
from robostar.commands.base import Command
from robostar.commands.motion import JogStop
from robostar.errors import OutcomeUnknownError
from robostar.sim import VirtualController
from robostar.transport import AsyncPeerTransport, PeerTransport

from .conftest import sim_config
from .jog_fakes import INTERVAL, INTERVALS, Arrivals, SimulatedClock, wait_for

pytestmark = pytest.mark.timeout(60)


@pytest.fixture
def controller() -> VirtualController:
    return VirtualController(sim_config(speedup=5.0))


def _after(arrivals: Arrivals, start: float, code: str) -> list[float]:
    return [t - start for t, c in arrivals.times if c == code and t >= start]


def test_a_jog_whose_hold_passes_stops_itself_while_the_body_hangs(
    controller: VirtualController,
) -> None:
    arrivals = Arrivals(controller)
    with Client(PeerTransport(arrivals), timeout=1.0) as client:
        started = time.monotonic()
        with client.jog(1, 1, "+") as jog:
            jog.held_until = lambda: started + 0.3
            time.sleep(1.2)  # the caller is stuck well past the hold: nobody stops the jog
            assert jog.expired
            assert not client.status()[0].running  # stopped before the block ends
        assert jog.error is None
    bfs = _after(arrivals, started, "BF")
    bgs = _after(arrivals, started, "BG")
    assert len(bgs) == 2, bgs  # the switch's BG, then the block's own
    assert bfs and max(bfs) < bgs[0], (bfs, bgs)  # no BF once the switch let go
    assert 0.3 <= bgs[0] < 0.3 + 0.3, bgs  # at the deadline, well before the body ends


def test_a_switch_given_at_construction_is_kept(controller: VirtualController) -> None:

    with Client(PeerTransport(controller), timeout=1.0) as client:
        started = time.monotonic()
        jog = Jog(
            client._urgent_call, jog_start(1, 1, "+", "joint"), 0.2, held_until=lambda: started
        )
        with jog:
            time.sleep(0.3)
            assert jog.expired
        assert controller.executions["BG"] == 2


def test_a_hold_that_keeps_being_extended_keeps_the_jog_alive(
    controller: VirtualController, jog_clock: SimulatedClock
) -> None:
    """Counted on a simulated clock, not timed: each interval a key repeat holds the jog 0.5 s
    more, and each brings its BF; the switch never lets go."""
    arrivals = Arrivals(controller)
    with Client(PeerTransport(arrivals), timeout=1.0, keepalive=INTERVAL) as client:
        held = [jog_clock.now + 0.5]
        with client.jog(1, 1, "+") as jog:
            jog.held_until = lambda: held[0]
            wait_for(lambda: jog_clock.reads > 0, "the keepalive's schedule")
            for sent in range(1, INTERVALS + 1):
                held[0] = jog_clock.now + 0.5  # a key repeat
                jog_clock.advance(INTERVAL)
                wait_for(lambda n=sent: arrivals.count("BF") >= n, f"BF number {sent}")  # type: ignore[misc]
            assert not jog.expired
            assert client.status()[0].running
    assert arrivals.count("BF") == INTERVALS
    assert arrivals.count("BG") == 1


def test_a_switch_that_fails_lets_go(controller: VirtualController) -> None:
    def broken() -> float:
        raise RuntimeError("the pad's state is gone")

    with Client(PeerTransport(controller), timeout=1.0) as client, client.jog(1, 1, "+") as jog:
        jog.held_until = broken
        time.sleep(0.5)
        assert jog.expired
        assert not client.status()[0].running


def test_async_jog_honours_the_switch_too(controller: VirtualController) -> None:
    arrivals = Arrivals(controller)

    async def main() -> None:
        async with AsyncClient(AsyncPeerTransport(arrivals), timeout=1.0) as client:
            started = time.monotonic()
            async with client.jog(1, 1, "+") as jog:
                jog.held_until = lambda: started + 0.3
                await asyncio.sleep(1.0)  # awaiting something else, past the hold
                assert jog.expired
                assert not (await client.status())[0].running
            assert jog.error is None
        bfs = _after(arrivals, started, "BF")
        bgs = _after(arrivals, started, "BG")
        assert bfs and bgs and max(bfs) < bgs[0], (bfs, bgs)

    asyncio.run(main())
    assert arrivals.count("BG") == 2


def test_client_jog_takes_the_switch(controller: VirtualController) -> None:
    # Client.jog(held_until=...) hands the switch to its Jog (as the jog pad does).
    arrivals = Arrivals(controller)
    with Client(PeerTransport(arrivals), timeout=1.0) as client:
        started = time.monotonic()
        with client.jog(1, 1, "+", held_until=lambda: started + 0.3) as jog:
            time.sleep(0.9)
            assert jog.expired
    assert _after(arrivals, started, "BG")


def test_async_client_jog_takes_the_switch() -> None:
    async def main() -> None:
        async with AsyncClient("sim://") as client:
            started = time.monotonic()
            async with client.jog(1, 1, "+", held_until=lambda: started + 0.3) as jog:
                await asyncio.sleep(0.9)
                assert jog.expired
            assert not (await client.status())[0].running

    asyncio.run(main())


def test_a_jog_start_of_unknown_outcome_is_stopped_at_once() -> None:
    # BE's answer lost: the axis may be moving and no keepalive follows; BG goes out at once
    # (not only the controller's watchdog 500 ms later), and the caller still hears why.
    sent: list[str] = []

    def call(command: Command[None]) -> None:
        sent.append(command.CODE)
        if command.CODE == "BE":
            raise OutcomeUnknownError("BE", "the answer was lost")

    start = jog_start(1, 1, "+", "joint")
    with pytest.raises(OutcomeUnknownError):
        Jog(call, start, 0.2).start()
    assert sent == ["BE", "BG"]

    async def acall(command: Command[None]) -> None:
        call(command)

    sent.clear()
    with pytest.raises(OutcomeUnknownError):
        asyncio.run(AsyncJog(acall, start, 0.2).start())
    assert sent == ["BE", "BG"] and JogStop(1).CODE == "BG"
