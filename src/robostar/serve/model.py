"""The live model of one controller: values with time and quality, fanned out to subscribers.

One poller writes; any number of consumers read or subscribe. A subscriber that stops reading
never slows the writer: its queue is bounded, keeps only the latest change per key and drops the
oldest key when full (counted in ``dropped``).
"""

from __future__ import annotations

import asyncio
import enum
import time
from collections import OrderedDict
from collections.abc import Collection
from dataclasses import dataclass, replace
from typing import Any, Self

__all__ = ["Change", "ControllerModel", "Quality", "Sample", "Subscription"]


class Quality(enum.Enum):
    """How far a value can be trusted."""

    GOOD = "good"
    STALE = "stale"
    LINE_DOWN = "line down"


@dataclass(frozen=True)
class Sample:
    """A value as read: ``at`` is the ``time.time()`` of the read (or of the status read that
    last confirmed it, see :meth:`ControllerModel.confirm`)."""

    value: Any
    at: float
    quality: Quality = Quality.GOOD

    @property
    def age(self) -> float:
        return max(0.0, time.time() - self.at)


@dataclass(frozen=True)
class Change:
    """A key of a line's model took a new sample."""

    line: str
    key: str
    sample: Sample


class Subscription:
    """An async iterator of :class:`Change`, bounded, coalescing per key."""

    def __init__(self, model: ControllerModel, maxsize: int) -> None:
        self._model = model
        self._maxsize = max(1, maxsize)
        self._pending: OrderedDict[str, Change] = OrderedDict()
        self._wake = asyncio.Event()
        self._closed = False
        self.dropped = 0
        """Changes lost because the consumer was slower than the model (oldest key first)."""

    def _offer(self, change: Change) -> None:
        if change.key in self._pending:
            # a newer value of a key not yet read replaces the older one: the reader wants state
            self._pending[change.key] = change
            self._pending.move_to_end(change.key)
        else:
            if len(self._pending) >= self._maxsize:
                self._pending.popitem(last=False)
                self.dropped += 1
            self._pending[change.key] = change
        self._wake.set()

    def close(self) -> None:
        """Stop receiving; a waiting ``__anext__`` ends the iteration."""
        if not self._closed:
            self._closed = True
            self._model._unsubscribe(self)
            self._wake.set()

    @property
    def closed(self) -> bool:
        return self._closed

    def pending(self) -> int:
        return len(self._pending)

    def get_nowait(self) -> Change | None:
        if not self._pending:
            return None
        _, change = self._pending.popitem(last=False)
        return change

    def __aiter__(self) -> Self:
        return self

    async def __anext__(self) -> Change:
        while not self._pending:
            if self._closed:
                raise StopAsyncIteration
            self._wake.clear()
            await self._wake.wait()
        _, change = self._pending.popitem(last=False)
        return change

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ControllerModel:
    """The latest known value of every key of one line (see docs/serve.md for the keys)."""

    def __init__(self, line: str) -> None:
        self.line = line
        self._values: dict[str, Sample] = {}
        self._subscribers: list[Subscription] = []
        self._valid_after = 0.0
        self.updates = 0
        """Samples stored since start (the bench's model update rate)."""

    def get(self, key: str) -> Sample | None:
        return self._values.get(key)

    def snapshot(self) -> dict[str, Sample]:
        return dict(self._values)

    def subscribe(self, *, maxsize: int = 1000) -> Subscription:
        sub = Subscription(self, maxsize)
        self._subscribers.append(sub)
        return sub

    def _unsubscribe(self, sub: Subscription) -> None:
        if sub in self._subscribers:
            self._subscribers.remove(sub)

    @property
    def subscribers(self) -> int:
        return len(self._subscribers)

    def set(self, key: str, value: Any, at: float | None = None) -> None:
        """Store a value just read; subscribers hear of it when the value or quality changed."""
        sample = Sample(value, time.time() if at is None else at, Quality.GOOD)
        old = self._values.get(key)
        self._values[key] = sample
        self.updates += 1
        if old is None or old.value != value or old.quality is not Quality.GOOD:
            self._publish(key, sample)

    def confirm(self, key: str, at: float) -> bool:
        """``key``'s good value still held at ``at`` (a status read vouches for it, see
        :mod:`robostar.serve.status_witness`): restamp it, as a read of the same value would,
        without telling subscribers (nothing changed). Whether it was restamped."""
        sample = self._values.get(key)
        if sample is None or sample.quality is not Quality.GOOD or sample.at >= at:
            return False
        self._values[key] = replace(sample, at=at)
        return True

    def fresh(self, key: str, max_age: float) -> Sample | None:
        """The sample of ``key`` if good, younger than ``max_age`` and newer than the last write."""
        sample = self._values.get(key)
        if sample is None or sample.quality is not Quality.GOOD:
            return None
        if sample.at < self._valid_after or sample.age > max_age:
            return None
        return sample

    def invalidate(self) -> None:
        """A state change happened: no value read before now may answer a read."""
        self._valid_after = time.time()

    def mark(self, quality: Quality, *, only: Quality | None = None) -> None:
        """Set the quality of every value (of those of quality ``only``, when given)."""
        for key, sample in self._values.items():
            if sample.quality is not quality and (only is None or sample.quality is only):
                self._values[key] = replace(sample, quality=quality)
                self._publish(key, self._values[key])

    def age_out(self, before: float, *, keep: Collection[str] = ()) -> None:
        """Mark STALE the good values read before ``before`` (a ``time.time()``), except the
        keys in ``keep`` (values that do not change while the line is up)."""
        for key, sample in self._values.items():
            if sample.quality is Quality.GOOD and sample.at < before and key not in keep:
                self._values[key] = replace(sample, quality=Quality.STALE)
                self._publish(key, self._values[key])

    def _publish(self, key: str, sample: Sample) -> None:
        change = Change(self.line, key, sample)
        for sub in self._subscribers:
            sub._offer(change)
