"""The raw-socket floor: two minimal Python processes exchanging the protocol's three messages.

The client sends a 7-byte request, reads an 8-byte answer, sends a 1-byte ACK; the server reads
the request, sends the answer, reads the ACK. Blocking sockets, Nagle off on both ends as in
robostar's transport and simulator. No framing, no checks: the fastest any Python host could
go on this machine, which the protocol stacks are measured against.

:func:`async_client_loop` is the asyncio twin, the floor of an asyncio host: an
``asyncio.Protocol`` whose ``data_received`` ACKs a whole answer at once and wakes the one
waiting task; the task writes the next request. No streams, no framing, no checks.

``python -m bench.floor`` runs the server on a free loopback port and prints ``host:port``.
``python -m bench.floor canned`` runs the same minimal server for robostar's client instead:
it reads a request up to its ETX and LRC, sends a fixed answer (AA or AC, made beforehand),
and reads the ACK. ``python -m bench.floor modbus`` does the same for pymodbus's client (read
10 holding registers: a 12-byte request, a 29-byte answer echoing its transaction id). Against
these, each client library is measured with a server as cheap as the floor's.
"""

from __future__ import annotations

import asyncio
import socket
import struct
import sys
import threading
import time

__all__ = [
    "ANSWER",
    "REQUEST",
    "AsyncFloor",
    "async_client_loop",
    "bound",
    "canned_answers",
    "client_loop",
    "connect",
    "serve",
]

REQUEST = b"\x02\xffAA\x03\xbe\x00"
ANSWER = b"\x02\x30\xbc\x84\x80\x03\x88\x00"
ACK = b"\x06"


def _take(sock: socket.socket, buf: bytes, n: int) -> tuple[bytes, bytes]:
    while len(buf) < n:
        chunk = sock.recv(4096)
        if not chunk:
            raise EOFError
        buf += chunk
    return buf[:n], buf[n:]


def _serve_one(conn: socket.socket) -> None:
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    buf = b""
    try:
        while True:
            _, buf = _take(conn, buf, len(REQUEST))
            conn.sendall(ANSWER)
            _, buf = _take(conn, buf, len(ACK))
    except (EOFError, OSError):
        pass
    finally:
        conn.close()


def canned_answers() -> dict[bytes, bytes]:
    """Framed answers by command letters, as the simulator would send them."""
    from bench.workload import POSITION, STATUS
    from robostar.commands.status import ReadPosition, ReadStatus
    from robostar.protocol.frame import encode_packet

    return {
        b"AA": encode_packet(ReadStatus().encode_answer(STATUS)[0]),
        b"AC": encode_packet(ReadPosition(1).encode_answer(POSITION)[0]),
    }


def _serve_canned(conn: socket.socket, answers: dict[bytes, bytes]) -> None:
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    buf = b""
    try:
        while True:
            while (end := buf.find(b"\x03")) < 0 or len(buf) < end + 2:
                chunk = conn.recv(4096)
                if not chunk:
                    return
                buf += chunk
            start = buf.find(b"\x02")
            request, buf = buf[start : end + 2], buf[end + 2 :]
            conn.sendall(answers[request[2:4]])
            _, buf = _take(conn, buf, len(ACK))
    except (EOFError, OSError):
        pass
    finally:
        conn.close()


_MODBUS_REQUEST = 12
_MODBUS_ANSWER_TAIL = b"\x00\x00\x00\x17\x01\x03\x14" + bytes(range(20))
"""After the echoed transaction id: protocol 0, length 23, unit 1, function 3, 20 data bytes."""


def _serve_modbus(conn: socket.socket) -> None:
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    buf = b""
    try:
        while True:
            request, buf = _take(conn, buf, _MODBUS_REQUEST)
            conn.sendall(request[:2] + _MODBUS_ANSWER_TAIL)
    except (EOFError, OSError):
        pass
    finally:
        conn.close()


MODES = ("floor", "canned", "modbus")


def serve(mode: str = "floor") -> None:
    """Serve clients, forever (until SIGTERM)."""
    if mode == "canned":
        answers = canned_answers()

        def handler(conn: socket.socket) -> None:
            _serve_canned(conn, answers)
    elif mode == "modbus":
        handler = _serve_modbus
    else:
        handler = _serve_one
    with socket.create_server(("127.0.0.1", 0)) as listener:
        host, port = listener.getsockname()[:2]
        print(f"{host}:{port}", flush=True)
        while True:
            conn, _ = listener.accept()
            # A thread per client so that several may stay connected; they take turns.
            threading.Thread(target=handler, args=(conn,), daemon=True).start()


RECV_LIMIT = 10.0
"""A client's blocking read gives up after this many seconds (BlockingIOError)."""


def bound(sock: socket.socket, seconds: float = RECV_LIMIT) -> socket.socket:
    """Keep ``sock`` blocking but let the kernel end a read that waits ``seconds``: a stalled
    server fails the benchmark instead of hanging it, without a poll() before every read."""
    whole = int(seconds)
    sock.setsockopt(
        socket.SOL_SOCKET,
        socket.SO_RCVTIMEO,
        struct.pack("ll", whole, int((seconds - whole) * 1e6)),
    )
    return sock


def connect(address: str) -> socket.socket:
    host, port = address.rsplit(":", 1)
    sock = socket.create_connection((host, int(port)))
    sock.settimeout(None)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return bound(sock)


def client_loop(sock: socket.socket, *, seconds: float, limit: int) -> int:
    """Exchange until ``seconds`` pass or ``limit`` exchanges are done; returns the count."""
    end = time.perf_counter() + seconds
    done = 0
    while done < limit:
        sock.sendall(REQUEST)
        got = 0
        while got < len(ANSWER):
            chunk = sock.recv(4096)
            if not chunk:
                raise EOFError("floor server closed the connection")
            got += len(chunk)
        sock.sendall(ACK)
        done += 1
        if not done & 63 and time.perf_counter() >= end:
            break
    return done


class AsyncFloor(asyncio.Protocol):
    """The N1 exchange's host side as an asyncio.Protocol: a whole answer is ACKed where it
    lands and wakes the waiting task."""

    def __init__(self) -> None:
        self.transport: asyncio.Transport | None = None
        self.waiter: asyncio.Future[None] | None = None
        self.got = 0

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport

    def data_received(self, data: bytes) -> None:
        self.got += len(data)
        if self.got >= len(ANSWER):
            self.got = 0
            assert self.transport is not None and self.waiter is not None
            self.transport.write(ACK)
            self.waiter.set_result(None)

    def connection_lost(self, exc: Exception | None) -> None:
        if self.waiter is not None and not self.waiter.done():
            self.waiter.set_exception(EOFError("floor server closed the connection"))


async def async_connect(address: str) -> AsyncFloor:
    host, port = address.rsplit(":", 1)
    loop = asyncio.get_running_loop()
    _, protocol = await loop.create_connection(AsyncFloor, host, int(port))
    return protocol


async def async_client_loop(protocol: AsyncFloor, *, seconds: float, limit: int) -> int:
    """:func:`client_loop` on asyncio."""
    loop = asyncio.get_running_loop()
    transport = protocol.transport
    assert transport is not None
    end = time.perf_counter() + seconds
    done = 0
    while done < limit:
        protocol.waiter = waiter = loop.create_future()
        transport.write(REQUEST)
        await waiter
        done += 1
        if not done & 63 and time.perf_counter() >= end:
            break
    return done


if __name__ == "__main__":
    chosen = sys.argv[1] if len(sys.argv) > 1 else "floor"
    if chosen not in MODES:
        raise SystemExit(f"mode: {chosen!r} is not one of {', '.join(MODES)}")
    serve(chosen)
