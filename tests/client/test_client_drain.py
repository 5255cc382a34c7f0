"""Stray input before a request, over TCP: both clients hand it to the idle link first.

A controller resending its answer (our ACK was lost on the way) leaves a copy on the line
before the next request; the client ACKs it again before it writes the request, so the copy
cannot pass for the next request's answer. Anything else stray is answered with RST.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from robostar import AsyncClient, Client
from robostar.errors import RobostarError
from robostar.protocol.frame import encode_packet

REQUEST = encode_packet(b"\xffAA")
ANSWER = encode_packet(b"0\x84\x84\x80")
ACK = b"\x06"
RST = b"\x12"


class Scripted:
    """Answers each AA at once; after the first exchange's ACK it sends ``stray``."""

    def __init__(self, stray: bytes) -> None:
        self.stray = stray
        self.received = bytearray()
        self.listener = socket.create_server(("127.0.0.1", 0))
        host, port = self.listener.getsockname()[:2]
        self.address = f"tcp://{host}:{port}"
        self.stray_sent = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        conn, _ = self.listener.accept()
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        answered = 0
        with conn:
            while True:
                data = conn.recv(4096)
                if not data:
                    return
                self.received += data
                while self.received.count(REQUEST) > answered:
                    answered += 1
                    conn.sendall(ANSWER)
                if answered == 1 and self.received.endswith(ACK) and not self.stray_sent.is_set():
                    conn.sendall(self.stray)
                    self.stray_sent.set()

    def everything_received(self) -> bytes:
        """All the client wrote, once it has closed the connection (the last ACK may still be
        on its way when the client returns)."""
        self.thread.join(5.0)
        assert not self.thread.is_alive()
        return bytes(self.received)

    def close(self) -> None:
        self.listener.close()


@pytest.fixture(params=["copy of the last answer", "another packet"])
def server(request: pytest.FixtureRequest) -> Iterator[tuple[Scripted, bytes]]:
    if request.param == "copy of the last answer":
        stray, reply = ANSWER, ACK  # the controller's resend: ACKed again
    else:
        stray, reply = encode_packet(b"0\x80\x80\x80"), RST  # stale: stopped with RST
    scripted = Scripted(stray)
    yield scripted, reply
    scripted.close()


def _wait_for_stray(scripted: Scripted) -> None:
    assert scripted.stray_sent.wait(5.0)
    time.sleep(0.05)  # on its way over loopback: in the client's socket by now


def test_the_blocking_client_drains_stray_input_first(server: tuple[Scripted, bytes]) -> None:
    scripted, reply = server
    with Client(scripted.address, timeout=1.0) as client:
        client.status()
        _wait_for_stray(scripted)
        client.status()
    assert scripted.everything_received() == REQUEST + ACK + reply + REQUEST + ACK


def test_the_asyncio_client_drains_stray_input_first(server: tuple[Scripted, bytes]) -> None:
    scripted, reply = server

    async def main() -> None:
        async with AsyncClient(scripted.address, timeout=1.0) as client:
            await client.status()
            await asyncio.to_thread(_wait_for_stray, scripted)
            await client.status()

    asyncio.run(main())
    assert scripted.everything_received() == REQUEST + ACK + reply + REQUEST + ACK


def _gr_answer(value: int) -> bytes:
    from robostar.protocol.packets import make_answer

    return encode_packet(make_answer(0x30, b"%6d" % value))


def _read_right_after(first: Callable[[bytes, int], Any]) -> int:
    """g10 read on a controller scripted by ``first`` for its first request, then g20 read
    2 ms after that call returns (every later request answered in 20 ms with 101 x index)."""
    from robostar.transport import PeerTransport

    from .test_client_hostile_controller import Scripted

    def script(data: bytes, n: int) -> Any:
        if n == 1:
            return first(data, n)
        return [(0.02, _gr_answer(int(data[4:].decode()) * 101))]

    with Client(PeerTransport(Scripted(script)), timeout=0.5) as client:
        with contextlib.suppress(RobostarError):
            client.read_global_int(10)
        time.sleep(0.002)
        return client.read_global_int(20)


def test_a_packet_doubled_by_the_line_is_drained_not_taken_for_the_next_answer() -> None:
    """Strays come sooner than a controller's resend: the line doubling a packet 1 ms after
    the answer. A read right after (2 ms) must drain it, not take it as its own answer (a
    review found a 5 ms no-drain window took g10's value for g20's, 20 of 20)."""
    for _ in range(5):
        assert (
            _read_right_after(lambda data, n: [(0.0, _gr_answer(1010)), (0.001, _gr_answer(1010))])
            == 2020
        )


def test_a_packet_behind_a_controllers_rst_is_drained() -> None:
    """The controller resets the exchange, then a stale packet follows 1 ms behind: the next
    read drains it (answered with RST) and gets its own answer."""
    for _ in range(5):
        assert (
            _read_right_after(lambda data, n: [(0.0, bytes((0x12,))), (0.001, _gr_answer(7777))])
            == 2020
        )
