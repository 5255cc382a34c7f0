"""The reconnect backoff policy shared by the line worker and the MQTT face: its waits grow
from ``initial`` by ``factor`` up to ``cap``, jitter only shortens a wait within its share,
and a policy that cannot work is refused when made."""

from __future__ import annotations

import asyncio
import contextlib
import logging

import aiomqtt
import pytest

from robostar.serve.backoff import Backoff
from robostar.serve.faces.mqtt import connection
from robostar.serve.line import _RECONNECT


def test_the_waits_double_from_initial_up_to_the_cap() -> None:
    policy = Backoff(initial=0.5, factor=2.0, cap=30.0)
    assert [policy.delay(n) for n in range(8)] == [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 30.0, 30.0]


def test_the_line_reopens_after_0_2_s_growing_to_10_s() -> None:
    assert [_RECONNECT.delay(n) for n in range(7)] == [0.2, 0.4, 0.8, 1.6, 3.2, 6.4, 10.0]


def test_a_very_long_outage_stays_at_the_cap() -> None:
    # No overflow of factor ** attempt after days of retries.
    assert Backoff(initial=0.2, factor=2.0, cap=10.0).delay(100_000) == 10.0


def test_a_cap_below_initial_caps_every_wait() -> None:
    # The MQTT face's reconnect_max may be set below its 0.5 s start.
    policy = Backoff(initial=0.5, cap=0.1)
    assert [policy.delay(n) for n in range(3)] == [0.1, 0.1, 0.1]


def test_a_factor_of_one_is_a_constant_wait() -> None:
    assert {Backoff(initial=1.5, factor=1.0).delay(n) for n in range(5)} == {1.5}


def test_jitter_shortens_a_wait_within_its_share() -> None:
    policy = Backoff(initial=1.0, factor=2.0, cap=10.0, jitter=0.25)
    assert policy.delay(2, draw=lambda: 0.0) == 4.0
    assert policy.delay(2, draw=lambda: 0.5) == 3.5
    assert 3.0 < policy.delay(2, draw=lambda: 0.999999) < 3.001
    assert all(3.0 < policy.delay(2) <= 4.0 for _ in range(200))


def test_without_jitter_no_draw_is_made() -> None:
    def never() -> float:
        raise AssertionError("drew a random number without jitter")

    assert Backoff(initial=1.0).delay(1, draw=never) == 2.0


@pytest.mark.parametrize(
    "options",
    [
        {"initial": 0.0},
        {"initial": -1.0},
        {"initial": 1.0, "factor": 0.5},
        {"initial": 1.0, "cap": 0.0},
        {"initial": 1.0, "jitter": -0.1},
        {"initial": 1.0, "jitter": 1.5},
        {"initial": float("nan")},
    ],
)
def test_a_policy_that_cannot_work_is_refused(options: dict[str, float]) -> None:
    with pytest.raises(ValueError):
        Backoff(**options)


def test_a_negative_attempt_is_refused() -> None:
    with pytest.raises(ValueError):
        Backoff(initial=1.0).delay(-1)


class Refused:
    """A broker connection that fails as it opens (what aiomqtt raises when refused)."""

    async def __aenter__(self) -> None:
        raise aiomqtt.MqttError("refused")

    async def __aexit__(self, *exc: object) -> None:
        return None


def test_the_mqtt_face_retries_by_the_policy_capped_at_reconnect_max(
    caplog: pytest.LogCaptureFixture,
) -> None:
    lost: list[int] = []

    async def session(client: aiomqtt.Client) -> None:
        raise AssertionError("never connected")

    async def main() -> None:
        task = asyncio.create_task(
            connection.keep_connected(
                "test", Refused, session, lambda: lost.append(1), reconnect_max=0.05
            )
        )
        while len(lost) < 3:
            await asyncio.sleep(0.01)
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task

    with caplog.at_level(logging.WARNING, logger=connection.log.name):
        asyncio.run(main())
    waits = [r.getMessage() for r in caplog.records if "retrying in" in r.getMessage()]
    assert len(waits) >= 3
    assert all(w.endswith("retrying in 0.1 s") for w in waits)  # 0.05 s, shown as %.1f
