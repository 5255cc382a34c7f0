"""TCP transport: ``tcp://host:port``, with Nagle off so that each packet leaves at once."""

from __future__ import annotations

import contextlib
import math
import select
import socket
import struct
import sys

from robostar.errors import PortError
from robostar.transport.base import Transport
from robostar.transport.url import DEFAULT_TCP_PORT

__all__ = ["TcpTransport", "tcp_open_error"]

_RECV_SIZE = 4096

_BLOCKING_READS = sys.platform.startswith("linux")
"""On Linux a read that may wait long blocks in recv() itself, bounded by SO_RCVTIMEO: one
system call per answer instead of a poll() and a recv(). Elsewhere poll()/select() first."""

_RCVTIMEO = 0.1
"""The kernel ends a blocking recv() after this many seconds; a read allowed longer waits
the rest with poll(). Reads allowed less than this poll first."""


def tcp_open_error(url: str, exc: OSError) -> PortError:
    """A PortError saying why a TCP connection could not be made, and what to check."""
    if isinstance(exc, ConnectionRefusedError):
        hint = "connection refused; is the controller's gateway on and listening on that port?"
    elif isinstance(exc, socket.gaierror):
        hint = f"unknown host ({exc}); check the address"
    elif isinstance(exc, TimeoutError):
        hint = "no answer to the connection attempt; check the address, cable and firewall"
    else:
        hint = f"could not connect: {exc}"
    return PortError(f"{url}: {hint}")


class TcpTransport(Transport):
    """A TCP socket to a controller's serial gateway (or to the simulator's TCP server)."""

    def __init__(
        self,
        host: str,
        port: int = DEFAULT_TCP_PORT,
        *,
        connect_timeout: float = 5.0,
        url: str = "",
    ) -> None:
        self.host = host
        self.port = port
        self.connect_timeout = connect_timeout
        self.url = url or f"tcp://{host}:{port}"
        self._sock: socket.socket | None = None
        self._poll: select.poll | None = None
        self._send_flags = 0

    @property
    def is_open(self) -> bool:
        return self._sock is not None

    def open(self) -> None:
        if self._sock is not None:
            return
        try:
            sock = socket.create_connection((self.host, self.port), timeout=self.connect_timeout)
        except OSError as exc:
            raise tcp_open_error(self.url, exc) from exc
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        # No settimeout() before every call (it costs system calls on every exchange). On
        # Linux the socket blocks, each read bounded by SO_RCVTIMEO and each write made
        # non-blocking by its flag; elsewhere it is non-blocking once, waited on with
        # select() only when not ready.
        if _BLOCKING_READS:
            sock.setblocking(True)
            whole = int(_RCVTIMEO)
            timeval = struct.pack("ll", whole, round((_RCVTIMEO - whole) * 1e6))
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, timeval)
            self._send_flags = socket.MSG_DONTWAIT
        else:
            sock.setblocking(False)
            self._send_flags = 0
        self._sock = sock
        if hasattr(select, "poll"):  # not on Windows: select() there
            self._poll = select.poll()
            self._poll.register(sock, select.POLLIN)

    def close(self) -> None:
        sock, self._sock = self._sock, None
        self._poll = None
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.close()

    def _lost(self, exc: BaseException | None) -> PortError:
        self.close()
        detail = f" ({exc})" if exc else ""
        return PortError(f"{self.url}: the connection was lost{detail}")

    def write(self, data: bytes) -> None:
        sock = self._sock
        if sock is None:
            raise self._closed_error()
        if not data:
            return
        flags = self._send_flags
        try:
            try:
                sent = sock.send(data, flags)
            except BlockingIOError:
                sent = 0
            if sent == len(data):  # the usual case: a packet fits the socket's buffer at once
                return
            view = memoryview(data)[sent:]
            while view:
                try:
                    view = view[sock.send(view, flags) :]
                except BlockingIOError:
                    if not select.select([], [sock], [], self.connect_timeout)[1]:
                        raise TimeoutError("the connection stopped taking data") from None
        except OSError as exc:
            raise self._lost(exc) from exc

    def read(self, timeout: float) -> bytes:
        sock = self._sock
        if sock is None:
            raise self._closed_error()
        # Wait first, then read what is there: one poll and one recv per read, and no
        # exception on the normal path (a recv on an empty non-blocking socket raises). A
        # long wait on Linux is the recv itself (SO_RCVTIMEO bounds it; the rest is polled).
        poller = self._poll
        if not timeout and poller is not None and not poller.poll(0):
            return b""  # the drain's look before every request, in its fewest steps
        try:
            data = None
            if timeout >= _RCVTIMEO and _BLOCKING_READS:
                try:
                    data = sock.recv(_RECV_SIZE)
                except BlockingIOError:  # nothing for _RCVTIMEO s: wait the rest below
                    timeout -= _RCVTIMEO
            if data is None:
                if poller is not None:
                    # poll() counts whole milliseconds: round up, or a wait under 1 ms would
                    # spin.
                    if not poller.poll(math.ceil(timeout * 1000) if timeout > 0 else 0):
                        return b""
                elif not select.select([sock], [], [], max(timeout, 0.0))[0]:
                    return b""
                data = sock.recv(_RECV_SIZE)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise self._lost(exc) from exc
        if not data:
            raise self._lost(None)
        return data
