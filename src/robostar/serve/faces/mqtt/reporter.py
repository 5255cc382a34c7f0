"""Report by exception, with a deadband on positions and a rate cap per line (pure logic).

A change goes out only when it differs from what was last published (positions: by at least
the deadband on some axis; any change of quality always counts). Changes beyond the line's rate
(messages per second, bursts of one second's worth) wait, the latest per topic, and go out as
the rate allows: a moving robot cannot flood the broker, and the last value always arrives.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any

from robostar.serve.faces.mqtt.payload import within_deadband
from robostar.serve.model import Sample

__all__ = ["Reporter"]

_DEADBAND_KEYS = ("position", "angles")


class Reporter:
    def __init__(self, *, deadband: float, max_rate: float) -> None:
        self.deadband = deadband
        self.max_rate = max_rate
        self.suppressed = 0
        """Changes not sent because they were within the deadband or equal."""
        self._last: dict[str, tuple[Any, Any]] = {}
        self._held: OrderedDict[str, Sample] = OrderedDict()
        self._tokens = max_rate
        self._at: float | None = None

    def offer(self, key: str, sample: Sample) -> None:
        last = self._last.get(key)
        if last is not None and last[1] == sample.quality:
            band = self.deadband if key.endswith(_DEADBAND_KEYS) else 0.0
            if within_deadband(last[0], sample.value, band):
                self.suppressed += 1
                self._held.pop(key, None)
                return
        self._held[key] = sample
        self._held.move_to_end(key)

    def due(self, now: float) -> list[tuple[str, Sample]]:
        """The changes that may go out now, oldest first."""
        if self._at is not None:
            self._tokens = min(self.max_rate, self._tokens + (now - self._at) * self.max_rate)
        self._at = now
        out = []
        while self._held and self._tokens >= 1:
            key, sample = self._held.popitem(last=False)
            self._tokens -= 1
            self._last[key] = (sample.value, sample.quality)
            out.append((key, sample))
        return out

    @property
    def waiting(self) -> int:
        return len(self._held)

    def next_due(self, now: float) -> float | None:
        """When the rate next allows one (None: nothing waits)."""
        if not self._held:
            return None
        return now + max(0.0, (1 - self._tokens) / self.max_rate)

    def forget(self) -> None:
        """After a reconnect everything is published again from the snapshot."""
        self._last.clear()
