"""Line timing: a byte peer that makes bytes take the wire time of an RS-232C line.

The N1's line runs 8 data bits, no parity, 1 stop bit (115200 baud by default, manual 3.5): ten
bit times per byte. :class:`PacedPeer` charges that time both ways. A byte the host writes reaches
the wrapped peer when its last bit has crossed the wire; bytes the peer answers leave after a
turnaround delay and reach the host one byte time apart. Each byte is delivered at its own time
whatever the caller's polling rhythm, so a test can drive it with a fake clock and check exact
arrival times; :meth:`PacedPeer.next_deadline` names the end of the next pending burst, so a
server wakes once per burst and not once per byte.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from robostar.errors import UsageError
from robostar.transport.peer import BytePeer

__all__ = ["BITS_PER_BYTE", "PacedPeer"]

BITS_PER_BYTE = 10
"""Start bit, 8 data bits, stop bit."""

_EPSILON = 1e-9
"""Slack for float rounding when a caller polls at exactly a byte's arrival time."""


@dataclass(slots=True)
class _Burst:
    """Bytes sent back to back: byte ``i`` has fully arrived at ``start + (i + 1) * byte_time``."""

    start: float
    data: bytes
    done: int = 0  # bytes already handed on

    def arrived(self, now: float, byte_time: float) -> int:
        """How many bytes have fully arrived by ``now``."""
        if now <= self.start:
            return 0
        return min(len(self.data), int((now - self.start) / byte_time + _EPSILON))

    def time_of(self, i: int, byte_time: float) -> float:
        return self.start + (i + 1) * byte_time

    def end(self, byte_time: float) -> float:
        return self.start + len(self.data) * byte_time


class PacedPeer:
    """A byte peer that gives ``peer`` the timing of a serial line at ``baud``."""

    paced = True
    """Hosts sleep with microsecond timeouts for a paced peer."""

    def __init__(self, peer: BytePeer, *, baud: int = 115200, turnaround: float = 0.0) -> None:
        if isinstance(baud, bool) or not isinstance(baud, int) or baud <= 0:
            raise UsageError(f"baud: {baud!r} is not a positive whole number of bits per second")
        if (
            isinstance(turnaround, bool)
            or not isinstance(turnaround, int | float)
            or not math.isfinite(turnaround)
            or turnaround < 0
        ):
            raise UsageError(f"turnaround: {turnaround!r} is not a number of seconds (0 or more)")
        self.peer = peer
        self.baud = baud
        self.turnaround = float(turnaround)
        self.byte_time = BITS_PER_BYTE / baud
        """Seconds one byte takes on the wire."""
        self._rx: deque[_Burst] = deque()  # host -> peer, in flight
        self._tx: deque[_Burst] = deque()  # peer -> host, in flight
        self._rx_free = -math.inf  # when the host's wire is idle again
        self._tx_free = -math.inf  # when the peer's wire is idle again
        self._clock = -math.inf  # the latest time the wrapped peer was given

    # -- BytePeer ------------------------------------------------------------------------------
    def feed(self, data: bytes, now: float) -> None:
        self._advance(now)
        if data:
            start = max(now, self._rx_free)
            burst = _Burst(start, bytes(data))
            self._rx.append(burst)
            self._rx_free = burst.end(self.byte_time)

    def output(self, now: float) -> bytes:
        self._advance(now)
        self._collect(now)
        out = bytearray()
        while self._tx:
            burst = self._tx[0]
            n = burst.arrived(now, self.byte_time)
            out += burst.data[burst.done : n]
            burst.done = max(burst.done, n)
            if burst.done < len(burst.data):
                break
            self._tx.popleft()
        return bytes(out)

    def next_deadline(self) -> float | None:
        times = [queue[0].end(self.byte_time) for queue in (self._rx, self._tx) if queue]
        inner = self.peer.next_deadline()
        if inner is not None:
            times.append(inner)
        return min(times) if times else None

    # -- the work ------------------------------------------------------------------------------
    def _advance(self, now: float) -> None:
        """Replay, in time order, every byte arrival and peer deadline up to ``now``."""
        stuck: float | None = None  # a peer deadline that did not move when served
        while True:
            arrival = self._next_arrival()
            deadline = self.peer.next_deadline()
            if deadline is not None and deadline == stuck:
                deadline = None
            if (
                arrival is not None
                and arrival <= now + _EPSILON
                and (deadline is None or arrival <= deadline)
            ):
                burst = self._rx[0]
                byte = burst.data[burst.done : burst.done + 1]
                burst.done += 1
                if burst.done == len(burst.data):
                    self._rx.popleft()
                t = self._tick(arrival)
                self.peer.feed(byte, t)
                self._collect(t)
            elif deadline is not None and deadline <= now:
                self._collect(self._tick(deadline))
                if self.peer.next_deadline() == deadline:
                    stuck = deadline
            else:
                return

    def _next_arrival(self) -> float | None:
        if not self._rx:
            return None
        burst = self._rx[0]
        return burst.time_of(burst.done, self.byte_time)

    def _tick(self, t: float) -> float:
        # The wrapped peer must never see time run backwards.
        self._clock = max(self._clock, t)
        return self._clock

    def _collect(self, t: float) -> None:
        """Take what the peer has to say at ``t`` and put it on the wire."""
        t = self._tick(t)
        data = self.peer.output(t)
        if data:
            start = max(t + self.turnaround, self._tx_free)
            burst = _Burst(start, data)
            self._tx.append(burst)
            self._tx_free = burst.end(self.byte_time)
