"""A transport wrapper that counts the bytes crossing the line and notes when BE/BF leave."""

from __future__ import annotations

import time

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
        """Seconds spent outside ``read`` between reads: the host's own share of a transfer
        (acting on what arrived, writing, and getting to the next read)."""
        self._since: float | None = None

    @property
    def is_open(self) -> bool:
        return self.inner.is_open

    def open(self) -> None:
        self.inner.open()

    def close(self) -> None:
        self.inner.close()

    def write(self, data: bytes) -> None:
        self.inner.write(data)
        if data.startswith(_KEEPALIVE):
            self.keepalive_times.append(time.monotonic())
        self.sent += len(data)

    def read(self, timeout: float) -> bytes:
        entered = time.perf_counter()
        if self._since is not None:
            self.host_busy += entered - self._since
        data = self.inner.read(timeout)
        self.received += len(data)
        self._since = time.perf_counter()
        return data

    def restart_busy(self) -> None:
        """Count host time from the next read on."""
        self.host_busy = 0.0
        self._since = None

    @property
    def total(self) -> int:
        return self.sent + self.received
