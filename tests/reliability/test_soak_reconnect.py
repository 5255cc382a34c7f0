"""A short soak over loopback TCP, a TCP drop mid-exchange, reconnection, and a simulator
restart with its state directory.

The long soak (a million exchanges) is ``python reliability/run.py soak``.
"""

from __future__ import annotations

import signal
import tracemalloc
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from reliability.soak import run_soak, sim_process

from robostar.client import Client
from robostar.commands.base import Command
from robostar.commands.status import ReadStatus
from robostar.commands.variables import WriteGlobalInt
from robostar.errors import OutcomeUnknownError, PortError, ReplyTimeoutError
from robostar.sim import SimConfig, VirtualController
from robostar.sim.faults import FaultInjector, FaultKind
from robostar.sim.listeners import SimServer
from robostar.types import Point

LONG = 30.0
"""A reply timeout long enough that an error raised because of it could not be mistaken for
the immediate one a dropped connection must give."""


@pytest.fixture
def faulty_server() -> Iterator[tuple[SimServer, FaultInjector, VirtualController]]:
    sim = VirtualController(SimConfig(speedup=50))
    injector = FaultInjector(sim, seed=1)
    server = SimServer(injector).start()
    try:
        yield server, injector, sim
    finally:
        server.close()


def test_a_short_soak_has_no_error_and_no_wrong_result() -> None:
    with sim_process() as (proc, url):
        report = run_soak(url, 1400, sim_pid=proc.pid, samples=4)
    assert report.errors == {} and report.wrong == 0, report.first_errors


def test_memory_stays_flat_over_a_soak() -> None:
    # Python allocations of this process (the client) between two points of a soak: a leak of
    # even 50 bytes per exchange would show as 50 kB here.
    with sim_process() as (_, url), Client(url) as client:
        for _ in range(500):
            client.execute(ReadStatus())
        tracemalloc.start()
        try:
            for n in range(500):
                client.execute(WriteGlobalInt(3, n))
                client.execute(ReadStatus())
            first, _ = tracemalloc.get_traced_memory()
            for n in range(500):
                client.execute(WriteGlobalInt(3, n))
                client.execute(ReadStatus())
            second, _ = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
    assert second - first < 50_000, f"grew {second - first} bytes over 1000 exchanges"


@pytest.mark.parametrize(
    ("command", "error"),
    [(ReadStatus(), PortError), (WriteGlobalInt(1, 5), OutcomeUnknownError)],
    ids=["read", "write"],
)
@pytest.mark.parametrize("at_byte", [0, 2])
def test_a_tcp_drop_mid_exchange_raises_at_once(
    faulty_server: tuple[SimServer, FaultInjector, VirtualController],
    command: Command[Any],
    error: type[Exception],
    at_byte: int,
) -> None:
    server, injector, _ = faulty_server
    with Client(server.url, timeout=LONG) as client:
        client.status()
        injector.schedule(FaultKind.DISCONNECT, "to_host", at_byte=at_byte)
        with pytest.raises(error) as caught:
            client.execute(command)
        # Raised because the line dropped, not because LONG seconds passed.
        assert not isinstance(caught.value, ReplyTimeoutError)
        assert "lost" in str(caught.value)
        with pytest.raises(PortError, match="reconnect=True"):
            client.status()


def test_with_reconnect_the_next_call_reconnects(
    faulty_server: tuple[SimServer, FaultInjector, VirtualController],
) -> None:
    server, injector, sim = faulty_server
    with Client(server.url, timeout=LONG, reconnect=True) as client:
        client.write_global_int(2, 41)
        injector.schedule(FaultKind.DISCONNECT, "to_host", at_byte=1)
        with pytest.raises(OutcomeUnknownError):
            client.write_global_int(2, 42)
        # The next call opens a new connection; the write did reach the controller once.
        assert client.read_global_int(2) == 42
        assert sim.executions["GW"] == 2
        client.status()


def test_a_restarted_simulator_keeps_everything_acknowledged(tmp_path: Path) -> None:
    # The simulator saves before it answers; SIGKILL right after the last answer loses nothing.
    state = tmp_path / "state"
    lines = ["MAIN", "OUT 0,1,1", "EOP"]
    point = Point((11.0, 22.0, 33.0, 44.0))
    with sim_process(state) as (proc, url), Client(url) as client:
        client.write_global_int(10, 12345)
        client.write_global_float(11, -2.5)
        client.write_global_point(1, 12, point)
        client.set_speed(1, 777)
        client.set_output(1, 3, True)
        client.upload_job(1, "KEEP.JOB", lines, number=9)
        client.copy_file(1, "KEEP.JOB", "KEPT.JOB")
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    with sim_process(state) as (_, url), Client(url) as client:
        assert client.read_global_int(10) == 12345
        assert client.read_global_float(11) == -2.5
        assert client.read_global_point(1, 12).axes[:4] == point.axes
        assert client.speed(1) == 777
        assert client.outputs(1)[3] is True
        assert client.download_job(1, "KEEP.JOB").lines == tuple(lines)
        assert client.download_job(1, "KEPT.JOB").lines == tuple(lines)
