"""While consumers read, the poller keeps to its share of the line's time (``poll_share``):
after a poll exchange it waits so that its exchanges take at most that share, since a host's
read arriving during a long poll read must wait for its end; with no consumer reading, at the
default share, or with the model late, it never waits."""

from __future__ import annotations

import asyncio
import time

import pytest

from robostar.serve import LineConfig
from robostar.serve.config import ConfigError
from robostar.serve.line import Line


def _waits(share: float, *, consumer: bool, poll_age: float | None = 0.1) -> list[float]:
    """The pauses the poller takes after a 40 ms poll exchange."""
    line = Line(LineConfig("cell1", "sim://", poll_share=share))
    line.health.last_poll = None if poll_age is None else time.time() - poll_age
    pauses: list[float] = []
    real_sleep = asyncio.sleep

    async def sleep(seconds: float) -> None:
        pauses.append(seconds)
        await real_sleep(0)

    async def main() -> None:
        if consumer:
            line.poller.consumer_read()
        await line.poller._give_way(0.040)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(asyncio, "sleep", sleep)
        asyncio.run(main())
    return pauses


def test_the_poller_gives_way_to_reading_consumers() -> None:
    assert _waits(0.25, consumer=True) == [pytest.approx(0.120)]
    assert _waits(0.5, consumer=True) == [pytest.approx(0.040)]


def test_it_never_waits_unless_it_must() -> None:
    assert _waits(0.25, consumer=False) == []  # nobody reads: the wire is the poller's
    assert _waits(1.0, consumer=True) == []  # the default: no limit
    assert _waits(0.25, consumer=True, poll_age=1.5) == []  # late: freshness first


def test_a_small_share_never_waits_past_half_way_to_stale() -> None:
    # 40 ms at a share of 0.01 would be a 3.96 s pause; the model goes stale after 2 s without
    # a complete poll, and 0.1 s of it have gone: it waits the 0.9 s left to half-way only
    assert _waits(0.01, consumer=True) == [pytest.approx(0.9, abs=0.01)]


@pytest.mark.parametrize("share", [0.0, -0.5, 1.5, float("nan")])
def test_a_share_that_is_not_one_is_refused(share: float) -> None:
    with pytest.raises(ConfigError, match="poll_share"):
        LineConfig("cell1", "sim://", poll_share=share)
