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
from robostar.transport import Transport

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


class CountingDrains:
    """Counts the drain's reads (``read(0.0)``) a client makes on a simulator's line."""

    def __init__(self) -> None:
        from robostar.transport import transport_for_url

        self.inner = transport_for_url("sim://")
        self.drains = 0

    def wrap(self) -> Transport:
        counter, inner = self, self.inner

        class Counted(type(inner)):  # type: ignore[misc]
            def read(self, timeout: float) -> bytes:
                if timeout == 0.0:
                    counter.drains += 1
                return super().read(timeout)

        inner.__class__ = Counted
        return inner


def test_a_read_right_after_an_exchange_ended_in_order_needs_no_drain(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Within FRESH_LINE of an exchange that ended in order, a read goes out without the
    drain's read (no controller resends that soon); a state change always drains, and so does
    a read once the window has passed or after an exchange that did not end in order."""
    import robostar.client.sync as sync
    from robostar.commands.control import SetSpeed

    counting = CountingDrains()
    monkeypatch.setattr(sync, "FRESH_LINE", 3600.0)  # every call below falls inside it
    with Client(counting.wrap(), timeout=1.0) as client:
        client.status()
        assert counting.drains == 1  # the first exchange: nothing before it
        client.status()
        client.position(1)
        assert counting.drains == 1
        client.execute(SetSpeed(1, 50))  # a state change drains
        assert counting.drains == 2
        client.status()  # ... and ended in order: no drain for the read after it
        assert counting.drains == 2
        client._fresh_until = 0.0  # the window passed
        client.status()
        assert counting.drains == 3
    monkeypatch.setattr(sync, "FRESH_LINE", 0.0)
    counting = CountingDrains()
    with Client(counting.wrap(), timeout=1.0) as client:
        for _ in range(3):
            client.status()
        assert counting.drains == 3


def test_a_read_after_an_exchange_that_failed_drains(monkeypatch: pytest.MonkeyPatch) -> None:
    import robostar.client.sync as sync
    from robostar.errors import RobostarError

    monkeypatch.setattr(sync, "FRESH_LINE", 3600.0)
    counting = CountingDrains()
    with Client(counting.wrap(), timeout=0.2, retries=0) as client:
        client.status()
        assert counting.drains == 1
        # The controller goes silent for one exchange: it times out and ends with RST.
        peer = counting.inner
        real = peer.write
        peer.write = lambda data: None  # type: ignore[method-assign]
        with pytest.raises(RobostarError):
            client.status()
        peer.write = real  # type: ignore[method-assign]
        drains = counting.drains
        client.status()
        assert counting.drains == drains + 1
