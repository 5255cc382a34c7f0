"""In-process transports: drive a :class:`~robostar.transport.peer.BytePeer` with the real clock.

The peer (the simulator, or a fault injector around it) never blocks and owns no thread; these
transports give it ``time.monotonic()`` and, while the host waits for bytes, sleep until the
earlier of the read timeout and the peer's own next deadline, so its timers fire on time.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable

from robostar.transport.base import AsyncTransport, Transport
from robostar.transport.peer import BytePeer

__all__ = ["AsyncPeerTransport", "PeerTransport"]

# A peer whose deadline has passed but that has nothing to send yet is re-polled after this
# long, so that a peer which does not move its deadline cannot make the reader spin.
_MIN_NAP = 0.0005


class _InProcessBase:
    """What both in-process transports keep: the peer, the clock, and whether it is open."""

    def __init__(
        self,
        peer: BytePeer,
        *,
        url: str = "sim://",
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.peer = peer
        self.url = url
        self._clock = clock
        self._open = False

    @property
    def is_open(self) -> bool:
        return self._open

    def _deliver(self, data: bytes) -> None:
        self.peer.feed(bytes(data), self._clock())

    def _poll(self, now: float, end: float) -> tuple[bytes, float]:
        """The peer's bytes at ``now``, or how long to sleep before asking again (0: the
        read's time is up)."""
        data = self.peer.output(now)
        if data or now >= end:
            return data, 0.0
        deadline = self.peer.next_deadline()
        wake = end if deadline is None else min(end, deadline)
        return b"", min(max(wake - now, _MIN_NAP), end - now)


class PeerTransport(_InProcessBase, Transport):
    """A blocking transport whose far end is an in-process byte peer."""

    def open(self) -> None:
        self._open = True

    def close(self) -> None:
        self._open = False

    def write(self, data: bytes) -> None:
        if not self._open:
            raise self._closed_error()
        self._deliver(data)

    def read(self, timeout: float) -> bytes:
        if not self._open:
            raise self._closed_error()
        end = self._clock() + max(timeout, 0.0)
        while True:
            data, nap = self._poll(self._clock(), end)
            if data or not nap:
                return data
            time.sleep(nap)


class AsyncPeerTransport(_InProcessBase, AsyncTransport):
    """The asyncio twin of :class:`PeerTransport`."""

    async def open(self) -> None:
        self._open = True

    async def close(self) -> None:
        self._open = False

    async def write(self, data: bytes) -> None:
        if not self._open:
            raise self._closed_error()
        self._deliver(data)

    async def read(self, timeout: float) -> bytes:
        if not self._open:
            raise self._closed_error()
        # Always yield once, as a real line does: a task that calls the client in a loop must
        # not starve the others (the peer answers at once, so nothing else would suspend).
        await asyncio.sleep(0)
        end = self._clock() + max(timeout, 0.0)
        while True:
            data, nap = self._poll(self._clock(), end)
            if data or not nap:
                return data
            await asyncio.sleep(nap)
