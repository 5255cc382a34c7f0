"""A paced line counts a host's bytes from when the kernel received them, not from when the
serving thread woke to read them (Linux: SO_TIMESTAMPNS), and sleeps to just before a deadline
then polls: what keeps a simulated 115 200-baud line within a few per cent of its wire time."""

from __future__ import annotations

import socket
import struct
import sys
import time
from collections.abc import Iterator

import pytest

from robostar.serving import threaded
from robostar.serving.threaded import _arrival, _TcpStream

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="SO_TIMESTAMPNS")


@pytest.fixture
def pair() -> Iterator[tuple[socket.socket, socket.socket]]:
    with socket.create_server(("127.0.0.1", 0)) as listener:
        client = socket.create_connection(listener.getsockname())
        server, _ = listener.accept()
    server.setblocking(False)
    try:
        yield client, server
    finally:
        client.close()
        server.close()


@linux_only
def test_a_stamped_read_knows_when_the_bytes_arrived(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    client, server = pair
    stream = _TcpStream(server, "host", stamped=True)
    assert stream.stamped
    sent = time.monotonic()
    client.sendall(b"\x02AA\x03\x00")
    time.sleep(0.05)  # the serving thread is late to read: the arrival time is not
    assert stream.read() == b"\x02AA\x03\x00"
    assert stream.arrived is not None
    assert sent - 0.005 <= stream.arrived <= sent + 0.03
    assert time.monotonic() - stream.arrived >= 0.04


def test_an_unstamped_read_says_nothing_of_arrival(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    client, server = pair
    stream = _TcpStream(server, "host")
    client.sendall(b"x")
    time.sleep(0.01)
    assert stream.read() == b"x" and stream.arrived is None


def test_stamps_that_cannot_be_believed_are_ignored() -> None:
    now = time.time()

    def stamp(at: float) -> list[tuple[int, int, bytes]]:
        seconds = int(at)
        nanoseconds = int((at - seconds) * 1e9)
        payload = struct.pack("qq", seconds, nanoseconds)
        return [(socket.SOL_SOCKET, threaded._SO_TIMESTAMPNS, payload)]

    assert _arrival(stamp(now - 0.01)) is not None
    assert _arrival(stamp(now + 10)) is None  # from the future
    assert _arrival(stamp(now - 5)) is None  # too old to be this read's
    assert _arrival([]) is None
