"""Jogging: BF comes once per keepalive interval while other threads and tasks use the client,
and BG is sent however the jog ends - body exception, Ctrl-C, a failed keepalive, exit, SIGTERM.

The keepalive schedule runs here on a simulated clock that the test moves one interval at a
time, so "one BF per interval, whatever the other users of the client do" is counted, not
timed; the keepalives are counted where the controller sees them, at the simulator, as
requests arrive. How far under the controller's 500 ms the real gaps stay on a loaded machine
is a speed figure: ``python -m bench.jog`` measures it.
"""

from __future__ import annotations

import asyncio
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
from robostar.client.locks import AsyncPriorityLock, PriorityLock
from robostar.errors import OutcomeUnknownError, PortError
from robostar.sim import VirtualController
from robostar.sim import controller as controller_module
from robostar.sim.faults import FaultInjector
from robostar.sim.listeners import SimServer
from robostar.transport import AsyncPeerTransport, BytePeer, PeerTransport

from .conftest import sim_config
from .jog_fakes import GIVE_UP, INTERVAL, INTERVALS, Arrivals, SimulatedClock, wait_for

pytestmark = pytest.mark.timeout(60)


@pytest.fixture
def controller() -> VirtualController:
    return VirtualController(sim_config(speedup=5.0))


def one_keepalive_per_interval(arrivals: Arrivals, clock: SimulatedClock) -> None:
    """Move the clock one interval at a time: each brings exactly one BF, never more."""
    wait_for(lambda: arrivals.count("BE") == 1, "BE")
    # BE reads no clock: the first read is the keepalive's start of its schedule
    wait_for(lambda: clock.reads > 0, "the keepalive's schedule")
    for sent in range(1, INTERVALS + 1):
        assert arrivals.count("BF") == sent - 1  # none before it is due
        clock.advance(INTERVAL)
        wait_for(lambda n=sent: arrivals.count("BF") >= n, f"BF number {sent}")  # type: ignore[misc]
    wait_for(lambda: arrivals.count("AA") > 10, "the other users' turns")


def busy(client: Client, stop: threading.Event) -> None:
    """Another user of the same client: status polls and file downloads, back to back."""
    while not stop.is_set():
        client.status()
        client.download_job(1, "DEMO.JOB")
        client.position(1)


@pytest.mark.parametrize("line", ["memory", "tcp"])
def test_one_keepalive_per_interval_while_other_threads_use_the_client(
    controller: VirtualController, jog_clock: SimulatedClock, line: str
) -> None:
    arrivals = Arrivals(controller)
    server = SimServer(arrivals).start() if line == "tcp" else None
    port = server.url if server else PeerTransport(arrivals)
    try:
        with Client(port, timeout=1.0, keepalive=INTERVAL) as client:
            stop = threading.Event()
            workers = [threading.Thread(target=busy, args=(client, stop)) for _ in range(3)]
            for worker in workers:
                worker.start()
            try:
                with client.jog(1, 1, "+") as jog:
                    one_keepalive_per_interval(arrivals, jog_clock)
            finally:
                stop.set()
                for worker in workers:
                    worker.join()
            assert jog.error is None
    finally:
        if server is not None:
            server.close()
    assert arrivals.count("BF") == INTERVALS
    assert arrivals.count("BG") == 1
    jog_codes = [code for code in arrivals.codes if code in ("BE", "BF", "BG")]
    assert jog_codes == ["BE", *["BF"] * INTERVALS, "BG"]


def test_async_one_keepalive_per_interval_while_other_tasks_use_the_client(
    controller: VirtualController, jog_clock: SimulatedClock
) -> None:
    arrivals = Arrivals(controller)

    async def main() -> None:
        transport = AsyncPeerTransport(arrivals)
        async with AsyncClient(transport, timeout=1.0, keepalive=INTERVAL) as client:

            async def busy_task() -> None:
                while True:
                    await client.status()
                    await client.download_job(1, "DEMO.JOB")

            tasks = [asyncio.create_task(busy_task()) for _ in range(3)]
            async with client.jog(1, 1, "+") as jog:
                await asyncio.to_thread(one_keepalive_per_interval, arrivals, jog_clock)
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
            assert jog.error is None
            assert not (await client.status())[0].running

    asyncio.run(main())
    assert arrivals.count("BF") == INTERVALS
    assert arrivals.count("BG") == 1
    jog_codes = [code for code in arrivals.codes if code in ("BE", "BF", "BG")]
    assert jog_codes == ["BE", *["BF"] * INTERVALS, "BG"]


class Gate:
    """A byte peer in front of the simulator that, while :meth:`hold` lasts, keeps requests
    from reaching it (control bytes go through): the exchange in progress cannot end, so the
    client's other users queue for the line, and :meth:`release` lets them go in the order the
    client chooses."""

    def __init__(self, peer: BytePeer) -> None:
        self.peer = peer
        self._held: bytearray | None = None
        self.stuck = threading.Event()
        """Set when a request is held back."""

    def hold(self) -> None:
        self.stuck.clear()
        self._held = bytearray()

    def release(self, now: float) -> None:
        held, self._held = self._held, None
        if held:
            self.peer.feed(bytes(held), now)

    def feed(self, data: bytes, now: float) -> None:
        held = self._held
        if held is None:
            self.peer.feed(data, now)
            return
        start = data.find(b"\x02") if not held else 0  # ACKs before a request go through
        if start < 0:
            self.peer.feed(data, now)
            return
        if start:
            self.peer.feed(data[:start], now)
        held += data[start:]
        self.stuck.set()

    def output(self, now: float) -> bytes:
        return self.peer.output(now)

    def next_deadline(self) -> float | None:
        # a reader waiting for a held request's answer looks again soon after the release
        return time.monotonic() + 0.001 if self._held is not None else self.peer.next_deadline()


def waiting(lock: PriorityLock | AsyncPriorityLock) -> tuple[int, int]:
    """(urgent, all) callers waiting for the client's line (white box: no other view)."""
    if isinstance(lock, PriorityLock):
        return lock._urgent, lock._waiting
    waiters = [urgent for urgent, granted in list(lock._waiters) if not granted.done()]
    return sum(waiters), len(waiters)


def keepalive_goes_first(
    gate: Gate, arrivals: Arrivals, clock: SimulatedClock, lock: PriorityLock | AsyncPriorityLock
) -> None:
    """Hold an exchange of another user, let two more queue, make BF due: once the held
    exchange ends, the next request on the line is the BF, ahead of the users that waited
    longer."""
    wait_for(lambda: clock.reads > 0, "the keepalive's schedule")
    gate.hold()
    wait_for(gate.stuck.is_set, "an exchange in progress")
    wait_for(lambda: waiting(lock) == (0, 2), "two other users waiting for the line")
    clock.advance(INTERVAL)
    wait_for(lambda: waiting(lock) == (1, 3), "the keepalive waiting for the line")
    before = len(arrivals.codes)
    gate.release(time.monotonic())
    wait_for(lambda: arrivals.count("BF") == 1, "the BF")
    assert arrivals.codes[before] != "BF"  # the held request, the exchange in progress
    assert arrivals.codes[before + 1] == "BF", arrivals.codes[before:]


def test_a_due_keepalive_goes_before_the_other_threads_waiting(
    controller: VirtualController, jog_clock: SimulatedClock
) -> None:
    arrivals = Arrivals(controller)
    gate = Gate(arrivals)
    with Client(PeerTransport(gate), timeout=GIVE_UP, keepalive=INTERVAL) as client:
        stop = threading.Event()
        workers = [threading.Thread(target=busy, args=(client, stop)) for _ in range(3)]
        try:
            with client.jog(1, 1, "+") as jog:
                for worker in workers:
                    worker.start()
                keepalive_goes_first(gate, arrivals, jog_clock, client._lock)
        finally:
            stop.set()
            for worker in workers:
                worker.join()
        assert jog.error is None


def test_async_a_due_keepalive_goes_before_the_other_tasks_waiting(
    controller: VirtualController, jog_clock: SimulatedClock
) -> None:
    arrivals = Arrivals(controller)
    gate = Gate(arrivals)

    async def main() -> None:
        transport = AsyncPeerTransport(gate)
        async with AsyncClient(transport, timeout=GIVE_UP, keepalive=INTERVAL) as client:

            async def busy_task() -> None:
                while True:
                    await client.status()
                    await client.download_job(1, "DEMO.JOB")

            async with client.jog(1, 1, "+") as jog:
                tasks = [asyncio.create_task(busy_task()) for _ in range(3)]
                try:
                    await asyncio.to_thread(
                        keepalive_goes_first, gate, arrivals, jog_clock, client._lock
                    )
                finally:
                    for task in tasks:
                        task.cancel()
                    await asyncio.gather(*tasks, return_exceptions=True)
            assert jog.error is None

    asyncio.run(main())


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
            wait_for(lambda: jog.error is not None, "the keepalive failing")
        assert isinstance(caught.value.__cause__, OutcomeUnknownError)
        assert jog.error is caught.value.__cause__
        assert controller.executions["BG"] == 1


def test_a_line_lost_mid_jog_is_a_jog_interrupted_error_with_bgs_outcome(
    controller: VirtualController,
) -> None:
    faults = FaultInjector(controller, seed=5)
    with Client(PeerTransport(faults), timeout=0.15) as client:
        with pytest.raises(JogInterruptedError) as caught, client.jog(1, 1, "+") as jog:
            faults.schedule("disconnect", "to_host", at_byte=0)  # the line goes dead
            wait_for(lambda: jog.error is not None, "the keepalive failing")
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
    sys.stdin.readline()  # the test saw a keepalive arrive
    sys.exit(0)
with client.jog(1, 1, "+"):
    print("jogging", flush=True)
    time.sleep(30)
"""


@pytest.fixture
def served(
    controller: VirtualController, monkeypatch: pytest.MonkeyPatch
) -> Iterator[tuple[VirtualController, SimServer]]:
    """The simulator served here for a child process. Its jog watchdog (500 ms, real seconds)
    is set out of reach: a child started on a loaded machine may send its first BF late, and
    what these tests check is how the jog ends, not the watchdog."""
    monkeypatch.setattr(controller_module, "JOG_WATCHDOG", 3600.0)
    with SimServer(controller) as server:
        yield controller, server


def run_child(
    served: tuple[VirtualController, SimServer], mode: str, tmp_path: Path, *, terminate: bool
) -> tuple[int, str]:
    """Run the child until its jog is alive (a BF reached the controller), then end it: by
    SIGTERM, or by telling it to exit."""
    controller, server = served
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[2] / "src")}
    child = subprocess.Popen(
        [sys.executable, str(script), server.url, mode],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )
    assert child.stdout is not None
    assert child.stdout.readline().strip() == "jogging"
    wait_for(lambda: controller.executions["BF"] >= 1, "the child's first keepalive")
    if terminate:
        child.send_signal(signal.SIGTERM)
    out, _ = child.communicate("exit\n", timeout=GIVE_UP)
    return child.returncode, out


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM as POSIX sends it")
def test_sigterm_sends_bg_and_exits_as_terminated(
    served: tuple[VirtualController, SimServer], tmp_path: Path
) -> None:
    controller, _ = served
    code, _ = run_child(served, "plain", tmp_path, terminate=True)
    assert code == 128 + signal.SIGTERM
    assert controller.executions["BE"] == 1 and controller.executions["BF"] >= 1
    assert controller.executions["BG"] == 1


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM as POSIX sends it")
def test_sigterm_chains_to_the_applications_handler(
    served: tuple[VirtualController, SimServer], tmp_path: Path
) -> None:
    controller, _ = served
    code, out = run_child(served, "app-handler", tmp_path, terminate=True)
    assert code == 3 and "app handler" in out
    assert controller.executions["BG"] == 1


def test_a_jog_left_running_is_stopped_at_exit(
    served: tuple[VirtualController, SimServer], tmp_path: Path
) -> None:
    controller, _ = served
    code, _ = run_child(served, "no-with", tmp_path, terminate=False)
    assert code == 0
    assert controller.executions["BF"] >= 1
    assert controller.executions["BG"] == 1
