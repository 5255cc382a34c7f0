"""A line's health: what a dashboard or a metrics scrape wants to know about it."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

__all__ = ["LineHealth"]


@dataclass
class LineHealth:
    """What a dashboard or a metrics scrape wants to know about a line."""

    up: bool = False
    last_error: str | None = None
    latency: float | None = None
    """Duration of the last exchange, seconds."""
    exchanges: int = 0
    errors: int = 0
    reconnects: int = 0
    last_poll: float | None = None
    """``time.time()`` of the end of the last complete poll cycle."""
    latencies: list[float] = field(default_factory=list, repr=False)
    """Recent exchange durations (bounded), for the metrics histogram."""

    @property
    def poll_age(self) -> float | None:
        return None if self.last_poll is None else max(0.0, time.time() - self.last_poll)

    def count(self, elapsed: float, *, error: bool) -> None:
        """One exchange done, in ``elapsed`` seconds (``error``: it failed)."""
        self.exchanges += 1
        self.latency = elapsed
        self.latencies.append(elapsed)
        if len(self.latencies) > 1000:
            del self.latencies[:500]
        if error:
            self.errors += 1
