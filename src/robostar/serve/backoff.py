"""The one backoff policy for reconnecting: the line worker's and the MQTT face's.

A lost line or broker is tried again after a wait that starts at ``initial`` seconds and grows
by ``factor`` each failed attempt up to ``cap``; ``jitter`` (0 to 1) draws each wait at random
from the top ``jitter`` share of that range, so that many faces losing one broker at once do
not all knock again at the same instant. The attempt count is the caller's: it resets it once
a connection is made.
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["Backoff"]


@dataclass(frozen=True, slots=True)
class Backoff:
    """``delay(n)``: the wait (s) before attempt ``n + 1`` after ``n + 1`` failures in a row."""

    initial: float
    factor: float = 2.0
    cap: float = 30.0
    jitter: float = 0.0

    def __post_init__(self) -> None:
        if not self.initial > 0.0:
            raise ValueError(f"backoff initial must be above 0 s, not {self.initial!r}")
        if not self.factor >= 1.0:
            raise ValueError(f"backoff factor must be at least 1, not {self.factor!r}")
        if not self.cap > 0.0:  # below initial is allowed: then every wait is the cap
            raise ValueError(f"backoff cap must be above 0 s, not {self.cap!r}")
        if not 0.0 <= self.jitter <= 1.0:
            raise ValueError(f"backoff jitter must be within 0..1, not {self.jitter!r}")

    def delay(self, attempt: int, draw: Callable[[], float] = random.random) -> float:
        """The wait after failed attempt ``attempt`` (0 for the first failure); ``draw``
        gives a number in [0, 1) for the jitter."""
        if attempt < 0:
            raise ValueError(f"attempt must be 0 or more, not {attempt}")
        # The cap is reached long before the power overflows: stop growing there.
        wait = self.initial
        for _ in range(attempt):
            wait *= self.factor
            if wait >= self.cap:
                break
        wait = min(wait, self.cap)
        if self.jitter:
            wait -= wait * self.jitter * draw()
        return wait
