"""Stray input before a request, over TCP: both clients hand it to the idle link first.

A controller resending its answer (our ACK was lost on the way) leaves a copy on the line
before the next request; the client ACKs it again before it writes the request, so the copy
cannot pass for the next request's answer. Anything else stray is answered with RST.
"""

from __future__ import annotations

import asyncio
import socket
import threading
import time
from collections.abc import Iterator

import pytest

from robostar import AsyncClient, Client
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
