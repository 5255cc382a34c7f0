"""The jog's dead-man's switch (``held_until``): once the time it gives has passed, the keepalive
itself stops sending BF and sends BG, so a jog ends even when the code that should end it hangs
(the jog pad's screen write blocked by Ctrl-S). Without a switch a jog runs until stopped.

Where the schedule matters (a BF before the hold passes, BG at the hold and not an interval
later) the jog runs on a simulated clock that the test moves; elsewhere the test waits for what
it needs (the switch letting go) instead of sleeping for it."""

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


HOLD = 0.3
"""Simulated seconds a jog is held: after one keepalive interval, before the second."""


def past_the_hold(arrivals: Arrivals, clock: SimulatedClock, jog: Jog | AsyncJog) -> None:
    """Move the clock to a BF, then to the end of the hold, between two keepalives: the switch
    lets go there, not an interval later, and sends BG itself."""
    wait_for(lambda: clock.reads > 0, "the keepalive's schedule")
    clock.advance(INTERVAL)
    wait_for(lambda: arrivals.count("BF") == 1, "the BF before the hold passes")
    clock.advance(HOLD - INTERVAL)
    wait_for(lambda: arrivals.count("BG") == 1, "the switch's BG")
    assert jog.expired
    assert arrivals.count("BF") == 1  # none once the switch let go


def test_a_jog_whose_hold_passes_stops_itself_while_the_body_hangs(
    controller: VirtualController, jog_clock: SimulatedClock
) -> None:
    arrivals = Arrivals(controller)
    held = jog_clock.now + HOLD
    with Client(PeerTransport(arrivals), timeout=1.0, keepalive=INTERVAL) as client:
        with client.jog(1, 1, "+") as jog:
            jog.held_until = lambda: held
            past_the_hold(arrivals, jog_clock, jog)  # the caller is stuck: nobody stops the jog
            assert not client.status()[0].running  # stopped before the block ends
        assert jog.error is None
    jog_codes = [code for code in arrivals.codes if code in ("BE", "BF", "BG")]
    assert jog_codes == ["BE", "BF", "BG", "BG"]  # the switch's BG, then the block's own


def test_a_switch_given_at_construction_is_kept(controller: VirtualController) -> None:

    with Client(PeerTransport(controller), timeout=1.0) as client:
        started = time.monotonic()
        jog = Jog(
            client._urgent_call, jog_start(1, 1, "+", "joint"), 0.2, held_until=lambda: started
        )
        with jog:
            wait_for(lambda: jog.expired, "the switch letting go")
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
        wait_for(lambda: jog.expired, "the switch letting go")
        assert not client.status()[0].running


def test_async_jog_honours_the_switch_too(
    controller: VirtualController, jog_clock: SimulatedClock
) -> None:
    arrivals = Arrivals(controller)
    held = jog_clock.now + HOLD

    async def main() -> None:
        transport = AsyncPeerTransport(arrivals)
        async with AsyncClient(transport, timeout=1.0, keepalive=INTERVAL) as client:
            async with client.jog(1, 1, "+") as jog:
                jog.held_until = lambda: held
                # awaiting something else, past the hold
                await asyncio.to_thread(past_the_hold, arrivals, jog_clock, jog)
                assert not (await client.status())[0].running
            assert jog.error is None

    asyncio.run(main())
    jog_codes = [code for code in arrivals.codes if code in ("BE", "BF", "BG")]
    assert jog_codes == ["BE", "BF", "BG", "BG"]


def test_client_jog_takes_the_switch(controller: VirtualController) -> None:
    # Client.jog(held_until=...) hands the switch to its Jog (as the jog pad does).
    arrivals = Arrivals(controller)
    with Client(PeerTransport(arrivals), timeout=1.0) as client:
        started = time.monotonic()
        with client.jog(1, 1, "+", held_until=lambda: started + 0.3) as jog:
            wait_for(lambda: jog.expired, "the switch letting go")
    assert arrivals.count("BG") == 2


def test_async_client_jog_takes_the_switch() -> None:
    async def main() -> None:
        async with AsyncClient("sim://") as client:
            started = time.monotonic()
            async with client.jog(1, 1, "+", held_until=lambda: started + 0.3) as jog:
                await asyncio.to_thread(wait_for, lambda: jog.expired, "the switch letting go")
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
