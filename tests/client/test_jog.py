"""Jogging: BF keeps coming within 500 ms while other threads and tasks use the client, and BG
is sent however the jog ends - body exception, Ctrl-C, a failed keepalive, exit, SIGTERM.

The 500 ms is the controller's rule (the manual: a jog stops without BF within 500 ms), so the
gaps are measured where the controller sees them: at the simulator, as requests arrive.
"""

from __future__ import annotations

import asyncio
import itertools
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from robostar.client import AsyncClient, Client, JogInterruptedError
from robostar.errors import OutcomeUnknownError, PortError
from robostar.protocol.frame import FrameDecoder, Packet
from robostar.sim import VirtualController
from robostar.sim.faults import FaultInjector
from robostar.sim.listeners import SimServer
from robostar.transport import AsyncPeerTransport, BytePeer, PeerTransport

from .conftest import sim_config

pytestmark = pytest.mark.timeout(60)

LIMIT = 0.5
MARGIN = 0.1
"""The gaps must stay this far under the controller's limit."""


class Arrivals:
    """A byte peer in front of the simulator that notes when each request arrives."""

    def __init__(self, peer: BytePeer) -> None:
        self.peer = peer
        self._decoder = FrameDecoder()
        self.times: list[tuple[float, str]] = []

    def feed(self, data: bytes, now: float) -> None:
        for event in self._decoder.feed(data):
            if isinstance(event, Packet) and event.data[:1] == b"\xff":
                self.times.append((now, event.data[1:3].decode()))
        self.peer.feed(data, now)

    def output(self, now: float) -> bytes:
        return self.peer.output(now)

    def next_deadline(self) -> float | None:
        return self.peer.next_deadline()

    def keepalive_gaps(self) -> list[float]:
        """Gaps from BE to the first BF and between BFs, up to BG."""
        times = [t for t, code in self.times if code in ("BE", "BF")]
        return [b - a for a, b in itertools.pairwise(times)]

    def count(self, code: str) -> int:
        return sum(1 for _, c in self.times if c == code)


@pytest.fixture
def controller() -> VirtualController:
    return VirtualController(sim_config(speedup=5.0))


def busy(client: Client, stop: threading.Event) -> None:
    """Another user of the same client: status polls and file downloads, back to back."""
    while not stop.is_set():
        client.status()
        client.download_job(1, "DEMO.JOB")
        client.position(1)


@pytest.mark.parametrize("line", ["memory", "tcp"])
def test_keepalives_stay_under_500_ms_while_other_threads_use_the_client(
    controller: VirtualController, line: str
) -> None:
    arrivals = Arrivals(controller)
    server = SimServer(arrivals).start() if line == "tcp" else None
    port = server.url if server else PeerTransport(arrivals)
    try:
        with Client(port, timeout=1.0) as client:
            stop = threading.Event()
            workers = [threading.Thread(target=busy, args=(client, stop)) for _ in range(3)]
            for worker in workers:
                worker.start()
            try:
                with client.jog(1, 1, "+") as jog:
                    time.sleep(2.0)
            finally:
                stop.set()
                for worker in workers:
                    worker.join()
            assert jog.error is None
    finally:
        if server is not None:
            server.close()
    gaps = arrivals.keepalive_gaps()
    assert len(gaps) >= 8
    assert max(gaps) < LIMIT - MARGIN, gaps
    assert arrivals.count("BG") == 1
    assert arrivals.count("AA") > 10  # the other threads did get their turns


def test_async_keepalives_stay_under_500_ms_while_other_tasks_use_the_client(
    controller: VirtualController,
) -> None:
    arrivals = Arrivals(controller)

    async def main() -> None:
        async with AsyncClient(AsyncPeerTransport(arrivals), timeout=1.0) as client:

            async def busy_task() -> None:
                while True:
                    await client.status()
                    await client.download_job(1, "DEMO.JOB")

            tasks = [asyncio.create_task(busy_task()) for _ in range(3)]
            async with client.jog(1, 1, "+"):
                await asyncio.sleep(2.0)
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
            assert not (await client.status())[0].running

    asyncio.run(main())
    gaps = arrivals.keepalive_gaps()
    assert len(gaps) >= 8
    assert max(gaps) < LIMIT - MARGIN, gaps
    assert arrivals.count("BG") == 1
    assert arrivals.count("AA") > 10


def test_ctrl_c_in_the_body_still_sends_bg(controller: VirtualController) -> None:
    with Client(PeerTransport(controller), timeout=1.0) as client:
        with pytest.raises(KeyboardInterrupt), client.jog(1, 1, "+"):
            time.sleep(0.25)
            raise KeyboardInterrupt
        assert controller.executions["BG"] == 1
        assert not client.status()[0].running


def test_a_failed_keepalive_is_reported_when_the_jog_ends(controller: VirtualController) -> None:
    faults = FaultInjector(controller, seed=3)
    with Client(PeerTransport(faults), timeout=0.15) as client:
        with pytest.raises(JogInterruptedError) as caught, client.jog(1, 1, "+") as jog:
            faults.schedule("drop", "to_host", at_byte=0, count=4)  # the next BF's answer
            time.sleep(0.8)
        assert isinstance(caught.value.__cause__, OutcomeUnknownError)
        assert jog.error is caught.value.__cause__
        assert controller.executions["BG"] == 1


def test_a_line_lost_mid_jog_is_a_jog_interrupted_error_with_bgs_outcome(
    controller: VirtualController,
) -> None:
    faults = FaultInjector(controller, seed=5)
    with Client(PeerTransport(faults), timeout=0.15) as client:
        with pytest.raises(JogInterruptedError) as caught, client.jog(1, 1, "+"):
            faults.schedule("disconnect", "to_host", at_byte=0)  # the line goes dead
            time.sleep(0.8)
        assert not isinstance(caught.value, PortError)
        assert caught.value.stop_error is not None  # BG could not be sent either
        assert "BG failed too" in str(caught.value)
        assert controller.executions["BG"] == 0


def test_close_stops_a_running_jog(controller: VirtualController) -> None:
    client = Client(PeerTransport(controller), timeout=1.0)
    jog = client.jog(1, 1, "-")
    jog.start()
    time.sleep(0.25)
    client.close()
    assert not jog.running
    assert controller.executions["BG"] == 1


# -- exit and SIGTERM, in a child process talking to a simulator served here ------------------
CHILD = """
import signal, sys, time
from robostar import Client

client = Client(sys.argv[1], timeout=1.0)
if sys.argv[2] == "app-handler":
    def on_term(signum, frame):
        print("app handler", flush=True)
        sys.exit(3)
    signal.signal(signal.SIGTERM, on_term)
if sys.argv[2] == "no-with":
    client.jog(1, 1, "+").start()
    print("jogging", flush=True)
    time.sleep(0.6)
    sys.exit(0)
with client.jog(1, 1, "+"):
    print("jogging", flush=True)
    time.sleep(30)
"""


@pytest.fixture
def served(controller: VirtualController) -> Iterator[tuple[VirtualController, SimServer]]:
    with SimServer(controller) as server:
        yield controller, server


def run_child(server: SimServer, mode: str, tmp_path: Path, *, terminate: bool) -> tuple[int, str]:
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[2] / "src")}
    child = subprocess.Popen(
        [sys.executable, str(script), server.url, mode],
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )
    assert child.stdout is not None
    assert child.stdout.readline().strip() == "jogging"
    if terminate:
        time.sleep(0.3)
        child.send_signal(signal.SIGTERM)
    out, _ = child.communicate(timeout=20)
    return child.returncode, out


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM as POSIX sends it")
def test_sigterm_sends_bg_and_exits_as_terminated(
    served: tuple[VirtualController, SimServer], tmp_path: Path
) -> None:
    controller, server = served
    code, _ = run_child(server, "plain", tmp_path, terminate=True)
    assert code == 128 + signal.SIGTERM
    assert controller.executions["BE"] == 1 and controller.executions["BF"] >= 1
    assert controller.executions["BG"] == 1


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM as POSIX sends it")
def test_sigterm_chains_to_the_applications_handler(
    served: tuple[VirtualController, SimServer], tmp_path: Path
) -> None:
    controller, server = served
    code, out = run_child(server, "app-handler", tmp_path, terminate=True)
    assert code == 3 and "app handler" in out
    assert controller.executions["BG"] == 1


def test_a_jog_left_running_is_stopped_at_exit(
    served: tuple[VirtualController, SimServer], tmp_path: Path
) -> None:
    controller, server = served
    code, _ = run_child(server, "no-with", tmp_path, terminate=False)
    assert code == 0
    assert controller.executions["BF"] >= 1
    assert controller.executions["BG"] == 1
