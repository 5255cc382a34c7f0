"""A token bucket: at most ``rate`` events a second on average, ``burst`` at once.

Shared by the faces that cap something per second: the MQTT face's publications per line, the
OPC UA face's password checks. Time comes from the caller (``now``) or from ``clock``.
"""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["TokenBucket"]


class TokenBucket:
    """Starts full; refills at ``rate`` tokens a second up to ``burst``."""

    def __init__(
        self, rate: float, burst: float, *, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.rate = rate
        self.burst = burst
        self._clock = clock
        self._tokens = float(burst)
        self._at: float | None = None

    def _refill(self, now: float | None) -> float:
        now = self._clock() if now is None else now
        if self._at is not None:
            self._tokens = min(self.burst, self._tokens + (now - self._at) * self.rate)
        self._at = now
        return now

    def take(self, now: float | None = None) -> bool:
        """Spend one token if there is one."""
        self._refill(now)
        if self._tokens < 1.0:
            return False
        self._tokens -= 1.0
        return True

    def next_at(self, now: float | None = None) -> float:
        """When a token will be there (``now`` if one is)."""
        now = self._refill(now)
        return now + max(0.0, (1.0 - self._tokens) / self.rate)
