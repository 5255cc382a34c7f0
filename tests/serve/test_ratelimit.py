"""The token bucket both faces' rate caps stand on."""

from __future__ import annotations

import pytest

from robostar.serve.ratelimit import TokenBucket


def test_a_bucket_starts_full_refills_at_its_rate_and_caps_at_its_burst() -> None:
    bucket = TokenBucket(rate=2.0, burst=3)
    assert [bucket.take(0.0) for _ in range(4)] == [True, True, True, False]
    assert bucket.next_at(0.0) == pytest.approx(0.5)
    assert bucket.take(0.5) and not bucket.take(0.5)
    assert [bucket.take(100.0) for _ in range(4)] == [True, True, True, False]  # capped


def test_a_bucket_reads_its_clock_when_not_told_the_time() -> None:
    now = [10.0]
    bucket = TokenBucket(rate=1.0, burst=1, clock=lambda: now[0])
    assert bucket.take() and not bucket.take()
    now[0] += 1.0
    assert bucket.take()
