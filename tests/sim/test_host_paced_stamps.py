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

from robostar.sim import SimConfig, VirtualController
from robostar.sim import host as sim_host
from robostar.sim.host import PeerHost, _arrival, _TcpStream
from robostar.sim.pacing import PacedPeer

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


def _stamps_flowing(client: socket.socket, stream: _TcpStream) -> bool:
    """Linux turns receive stamps on lazily (deferred work) when the first socket asks, so the
    first packets after asking may come unstamped: wait (at most 2 s) until one is stamped."""
    give_up = time.monotonic() + 2.0
    while time.monotonic() < give_up:
        client.sendall(b"w")
        time.sleep(0.01)
        if stream.read() == b"w" and stream.arrived is not None:
            return True
    return False


@linux_only
def test_a_stamped_read_knows_when_the_bytes_arrived(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    client, server = pair
    stream = _TcpStream(server, "host", stamped=True)
    assert stream.stamped
    assert _stamps_flowing(client, stream), "the kernel never stamped a packet"
    sent = time.monotonic()
    client.sendall(b"\x02AA\x03\x00")
    time.sleep(0.05)  # the serving thread is late to read: the arrival time is not
    assert stream.read() == b"\x02AA\x03\x00"
    assert stream.arrived is not None
    assert sent - 0.005 <= stream.arrived <= sent + 0.03
    assert time.monotonic() - stream.arrived >= 0.04


@linux_only
def test_a_paced_listener_has_stamps_on_before_the_first_host_connects() -> None:
    """Asked for on the listening socket, stamps are on by the time a host connects, and its
    very first packet is stamped (asked for only on the accepted socket, it may not be)."""
    with socket.create_server(("127.0.0.1", 0)) as listener:
        assert sim_host._ask_for_stamps(listener)
        time.sleep(0.05)  # a listener exists a while before hosts connect; the kernel's work runs
        for _ in range(5):  # each a fresh connection: every first packet stamped
            with socket.create_connection(listener.getsockname()) as client:
                server, _ = listener.accept()
                with server:
                    stream = _TcpStream(server, "host", stamped=True)
                    client.sendall(b"\x02AA\x03\x00")
                    time.sleep(0.01)
                    assert stream.read() == b"\x02AA\x03\x00"
                    assert stream.arrived is not None


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
        return [(socket.SOL_SOCKET, sim_host._SO_TIMESTAMPNS, payload)]

    assert _arrival(stamp(now - 0.01)) is not None
    assert _arrival(stamp(now + 10)) is None  # from the future
    assert _arrival(stamp(now - 5)) is None  # too old to be this read's
    assert _arrival([]) is None


@linux_only
def test_only_a_paced_host_asks_for_stamps_when_it_listens() -> None:
    for peer, wanted in (
        (PacedPeer(VirtualController(SimConfig())), 1),
        (VirtualController(SimConfig()), 0),
    ):
        host = PeerHost(peer)
        host.listen_tcp()
        try:
            (listener,) = host._listeners
            assert listener.getsockopt(socket.SOL_SOCKET, sim_host._SO_TIMESTAMPNS) == wanted
        finally:
            host.close()
