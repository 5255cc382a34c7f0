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
from robostar.serve.ratelimit import TokenBucket

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
        self._bucket = TokenBucket(max_rate, max_rate)

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
        out = []
        while self._held and self._bucket.take(now):
            key, sample = self._held.popitem(last=False)
            self._last[key] = (sample.value, sample.quality)
            out.append((key, sample))
        return out

    def holds(self, key: str) -> bool:
        """Whether a change of ``key`` waits to go out."""
        return key in self._held

    @property
    def waiting(self) -> int:
        return len(self._held)

    def next_due(self, now: float) -> float | None:
        """When the rate next allows one (None: nothing waits)."""
        if not self._held:
            return None
        return self._bucket.next_at(now)

    def mark_sent(self, key: str, sample: Sample) -> None:
        """``sample`` went out by another way (a birth): not to be sent again unless it changes."""
        self._last[key] = (sample.value, sample.quality)
        self._held.pop(key, None)

    def forget(self) -> None:
        """After a reconnect everything is published again from the snapshot."""
        self._last.clear()
