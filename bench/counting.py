"""A transport wrapper that counts the bytes crossing the line and notes when BE/BF leave."""

from __future__ import annotations

import time

from bench.measure import wire_seconds
from robostar.transport import Transport

__all__ = ["CountingTransport"]

_KEEPALIVE = (b"\x02\xffBE", b"\x02\xffBF")


class CountingTransport(Transport):
    """Wraps a blocking transport; counts bytes each way and keeps the send time of every jog
    start (BE) and keepalive (BF), the instants whose gaps the controller watches."""

    def __init__(self, inner: Transport) -> None:
        self.inner = inner
        self.url = inner.url
        self.sent = 0
        self.received = 0
        self.keepalive_times: list[float] = []
        self.host_busy = 0.0
        """Seconds the line waited on the host: from the end of what it last read (or the end
        of the wire time of what it last wrote) to its next write. The protocol is one way at
        a time, so nothing is on the wire then: this is the host's turnaround, the part of a
        transfer's time over the wire floor that is the host's own."""
        self._line_free: float | None = None

    @property
    def is_open(self) -> bool:
        return self.inner.is_open

    def open(self) -> None:
        self.inner.open()

    def close(self) -> None:
        self.inner.close()

    def write(self, data: bytes) -> None:
        now = time.perf_counter()
        free = self._line_free
        if free is not None and now > free:
            self.host_busy += now - free
        # what is written goes on the wire once what went before it has left
        self._line_free = max(now, free or now) + wire_seconds(len(data))
        self.inner.write(data)
        if data.startswith(_KEEPALIVE):
            self.keepalive_times.append(time.monotonic())
        self.sent += len(data)

    def read(self, timeout: float) -> bytes:
        data = self.inner.read(timeout)
        self.received += len(data)
        if data:
            self._line_free = time.perf_counter()
        return data

    def restart_busy(self) -> None:
        """Count host time from the next read on."""
        self.host_busy = 0.0
        self._line_free = None

    @property
    def total(self) -> int:
        return self.sent + self.received
