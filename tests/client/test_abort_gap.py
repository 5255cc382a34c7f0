"""The quiet gap after the host's own abort, over a line with real latency.

A serial device server with latency holds an answer on its way for longer than any short gap.
A reviewer cancelled ``read_global_int(10)`` on such a line (0.3 s each way) and the next
``read_global_int(20)`` returned g10's value: the host waited only ``abort_gap`` (50 ms) after
its RST, and g10's answer, already on its way, landed on the next request. Now only a stop goes
out after ``abort_gap``; any other request waits the whole gap.

The line here is real: the simulator over TCP, behind a loopback relay that holds every chunk
0.3 s in each direction, as a device server with latency does.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
import threading
import time
from collections.abc import Iterator

import pytest

from robostar import AsyncClient
from robostar.protocol.frame import RST, encode_packet
from robostar.sim.config import SimConfig
from robostar.sim.controller import VirtualController
from robostar.sim.server import SimServer

LATENCY = 0.3
TIMEOUT = 1.0  # over the 0.6 s round trip; the client's quiet gap after an RST is this long
G10, G20 = 1010, 2020
CF = encode_packet(b"\xffCF")


class DelayRelay:
    """A loopback TCP relay that delivers every chunk ``delay`` s after it arrived, in order,
    both ways; it records when each chunk from the client arrived."""

    def __init__(self, target: tuple[str, int], delay: float) -> None:
        self.target = target
        self.delay = delay
        self.from_client: list[tuple[float, bytes]] = []
        self.listener = socket.create_server(("127.0.0.1", 0))
        host, port = self.listener.getsockname()[:2]
        self.url = f"tcp://{host}:{port}"
        self._threads: list[threading.Thread] = []
        self._accept = threading.Thread(target=self._serve, daemon=True)
        self._accept.start()

    def _serve(self) -> None:
        try:
            client, _ = self.listener.accept()
        except OSError:
            return
        upstream = socket.create_connection(self.target)
        for sock in (client, upstream):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._pipe(client, upstream, record=True)
        self._pipe(upstream, client, record=False)

    def _pipe(self, src: socket.socket, dst: socket.socket, *, record: bool) -> None:
        queue: list[tuple[float, bytes]] = []
        ready = threading.Condition()

        def reader() -> None:
            while True:
                try:
                    data = src.recv(4096)
                except OSError:
                    data = b""
                now = time.monotonic()
                if record and data:
                    self.from_client.append((now, data))
                with ready:
                    queue.append((now + self.delay, data))
                    ready.notify()
                if not data:
                    return

        def writer() -> None:
            while True:
                with ready:
                    while not queue:
                        ready.wait()
                    due, data = queue.pop(0)
                time.sleep(max(0.0, due - time.monotonic()))
                if not data:
                    with contextlib.suppress(OSError):
                        dst.shutdown(socket.SHUT_WR)
                    return
                try:
                    dst.sendall(data)
                except OSError:
                    return

        for target in (reader, writer):
            thread = threading.Thread(target=target, daemon=True)
            thread.start()
            self._threads.append(thread)

    def sent_at(self, frame: bytes) -> float:
        """When the client's write holding ``frame`` reached the relay."""
        return next(at for at, data in self.from_client if frame in data)

    def rst_at(self) -> float:
        return next(at for at, data in self.from_client if bytes((RST,)) in data)

    def close(self) -> None:
        self.listener.close()


@pytest.fixture
def relay() -> Iterator[DelayRelay]:
    controller = VirtualController(SimConfig())
    with SimServer(controller) as server:
        line = DelayRelay(server.address, LATENCY)
        yield line
        line.close()


async def _cancel_a_read(client: AsyncClient, index: int) -> None:
    """Start ``read_global_int(index)`` and cancel it once its request is on its way (the
    answer is then already coming: the controller answers at once, 0.6 s round trip)."""
    task = asyncio.create_task(client.read_global_int(index))
    await asyncio.sleep(0.1)
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task


def test_a_read_after_an_aborted_read_gets_its_own_answer(relay: DelayRelay) -> None:
    # Before the fix: g20's read returned g10's value (the reviewer's case, 5 runs of 5).
    async def run() -> list[int]:
        async with AsyncClient(relay.url, timeout=TIMEOUT) as client:
            await client.write_global_int(10, G10)
            await client.write_global_int(20, G20)
            values = []
            for _ in range(2):
                await _cancel_a_read(client, 10)
                values.append(await client.read_global_int(20))
            return values

    assert asyncio.run(run()) == [G20, G20]


def test_a_stop_after_an_abort_goes_out_within_the_short_gap(relay: DelayRelay) -> None:
    async def run() -> tuple[int, float, float]:
        async with AsyncClient(relay.url, timeout=TIMEOUT) as client:
            await client.write_global_int(20, G20)
            await _cancel_a_read(client, 10)
            await client.emergency_stop()  # g10's answer, still coming, is not taken for CF's
            after_stop = await client.read_global_int(20)
            alarms = await client.alarms()
            await client.reset_alarms()
            return after_stop, relay.sent_at(CF) - relay.rst_at(), len(alarms)

    after_stop, stop_delay, alarms = asyncio.run(run())
    # The stop goes out after abort_gap (50 ms), not the whole gap (TIMEOUT); some slack for
    # a loaded machine.
    assert stop_delay < TIMEOUT / 2
    assert stop_delay >= 0.05 - 0.005
    assert alarms >= 1  # CF was carried out: "Host Emergency"
    assert after_stop == G20  # and nothing stale landed on the read after the stop
