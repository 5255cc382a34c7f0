"""Library changes proposed in docs/performance.md, tried out from the bench (not used by it).

:class:`LeanTcpTransport` is :class:`~robostar.transport.TcpTransport` with its system calls cut
from eleven per exchange to five: the socket is made non-blocking once, at open, instead of
``settimeout`` before every call (each a ``ioctl(FIONBIO)``, and each timed call a ``poll``
first); a write is a plain ``send``; a read waits in a ``poll`` registered once, then ``recv``.
Results measured with it are labelled as such and never stand in for the library's figures.
"""

from __future__ import annotations

import select

from robostar.errors import PortError
from robostar.transport import TcpTransport

__all__ = ["LeanTcpTransport"]

_RECV_SIZE = 4096


class LeanTcpTransport(TcpTransport):
    """The proposed ``TcpTransport``: same behaviour, fewer system calls."""

    def open(self) -> None:
        super().open()
        assert self._sock is not None
        self._sock.setblocking(False)
        self._poll = select.poll()
        self._poll.register(self._sock, select.POLLIN)
        self._poll_out = select.poll()
        self._poll_out.register(self._sock, select.POLLOUT)

    def write(self, data: bytes) -> None:
        sock = self._sock
        if sock is None:
            raise self._closed_error()
        view = memoryview(data)
        try:
            while view:
                try:
                    view = view[sock.send(view) :]
                except BlockingIOError:
                    if not self._poll_out.poll(self.connect_timeout * 1000):
                        raise self._lost(TimeoutError("write timed out")) from None
        except OSError as exc:
            raise self._lost(exc) from exc

    def read(self, timeout: float) -> bytes:
        sock = self._sock
        if sock is None:
            raise self._closed_error()
        try:
            if timeout > 0 and not self._poll.poll(timeout * 1000):
                return b""
            data = sock.recv(_RECV_SIZE)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise self._lost(exc) from exc
        if not data:
            raise self._lost(None)
        return data

    def _lost(self, exc: BaseException | None) -> PortError:
        return super()._lost(exc)
