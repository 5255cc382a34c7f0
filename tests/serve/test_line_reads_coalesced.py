"""Single-flight reads: identical reads waiting together cost one wire exchange, and every read
is answered by an exchange that began after it arrived (never one already on the wire); a
reader that goes away leaves its flight, and a flight nobody waits for is not sent."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path
from typing import Any

import pytest

from robostar.commands.base import Command
from robostar.commands.control import ReadSpeed
from robostar.commands.status import ReadStatus
from robostar.serve import LineConfig, Who
from robostar.serve.audit import AuditLog
from robostar.serve.line import Line, WithdrawnError

from .line_fakes import FaultySim, hold_the_line, wait_for

ANN = Who("ann", "n1")
BOB = Who("bob", "n1")


async def _quiet_line(sim: FaultySim, path: Path) -> Line:
    """A line whose poller stays out of the way (it polls every 5 s)."""
    audit = AuditLog(path)
    audit.open()
    config = LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0)
    line = Line(config, client_factory=sim.client, audit=audit)
    await line.start()
    await line.wait_polled()
    return line


def _count_statuses(sim: FaultySim) -> list[float]:
    """The ``time.time()`` at which each AA from now on goes out."""
    began: list[float] = []

    def note(command: Command[Any]) -> None:
        if isinstance(command, ReadStatus):
            began.append(time.time())

    sim.before.append(lambda command: note(command))
    return began


def test_sixteen_identical_reads_waiting_together_share_one_exchange(tmp_path: Path) -> None:
    sim = FaultySim()

    async def main() -> tuple[list[float], list[float], list[float]]:
        line = await _quiet_line(sim, tmp_path / "audit.jsonl")
        try:
            busy = await hold_the_line(line, sim)
            sent = _count_statuses(sim)
            arrived: list[float] = []

            async def one() -> float:
                arrived.append(time.time())
                _, began = await line.read_sample(ReadStatus())
                return began

            reads = [asyncio.create_task(one()) for _ in range(16)]
            assert await wait_for(lambda: len(arrived) == 16)
            sim.write_delay = 0.0
            began = list(await asyncio.gather(*reads))
            await busy
            return sent, arrived, began
        finally:
            await line.stop()

    sent, arrived, began = asyncio.run(main())
    assert len(sent) == 1
    assert all(b >= a for a, b in zip(arrived, began, strict=True))


def test_a_read_arriving_while_its_twin_is_on_the_wire_joins_the_next_exchange(
    tmp_path: Path,
) -> None:
    sim = FaultySim()

    async def main() -> tuple[list[float], float, float, float]:
        line = await _quiet_line(sim, tmp_path / "audit.jsonl")
        try:
            sent = _count_statuses(sim)
            sim.write_delay = 0.2
            first = asyncio.create_task(line.read_sample(ReadStatus()))
            assert await wait_for(
                lambda: line._current is not None and isinstance(line._current.command, ReadStatus)
            )
            asked = time.time()
            second = asyncio.create_task(line.read_sample(ReadStatus()))
            (_, first_began), (_, second_began) = await asyncio.gather(first, second)
            return sent, asked, first_began, second_began
        finally:
            await line.stop()

    sent, asked, first_began, second_began = asyncio.run(main())
    assert len(sent) == 2
    assert first_began < asked <= second_began


def test_a_host_read_refreshes_the_model_stamped_with_its_exchange(tmp_path: Path) -> None:
    sim = FaultySim()

    async def main() -> tuple[float, float | None]:
        line = await _quiet_line(sim, tmp_path / "audit.jsonl")
        try:
            _, began = await line.read_sample(ReadSpeed(1))
            sample = line.model.get("ch1/speed")
            return began, None if sample is None else sample.at
        finally:
            await line.stop()

    began, stamped = asyncio.run(main())
    assert stamped == began


def test_a_withdrawn_reader_leaves_the_flight_and_the_others_are_answered(
    tmp_path: Path,
) -> None:
    sim = FaultySim()

    async def main() -> None:
        line = await _quiet_line(sim, tmp_path / "audit.jsonl")
        try:
            busy = await hold_the_line(line, sim)
            sent = _count_statuses(sim)
            ann = asyncio.create_task(line.read(ReadStatus(), who=ANN))
            bob = asyncio.create_task(line.read(ReadStatus(), who=BOB))
            assert await wait_for(lambda: line._reads_waiting == 3)  # and the one holding the line
            assert line.withdraw(ANN, "ann went away") == 1
            with pytest.raises(WithdrawnError, match="ann went away"):
                await ann
            assert len(await bob) == 3
            await busy
            assert len(sent) == 1
        finally:
            await line.stop()

    asyncio.run(main())


def test_a_flight_nobody_waits_for_is_not_sent(tmp_path: Path) -> None:
    sim = FaultySim()

    async def main() -> None:
        line = await _quiet_line(sim, tmp_path / "audit.jsonl")
        try:
            busy = await hold_the_line(line, sim)
            sent = _count_statuses(sim)
            reads = [asyncio.create_task(line.read(ReadStatus())) for _ in range(3)]
            assert await wait_for(lambda: line._reads_waiting == 4)  # and the one holding the line
            for read in reads:
                read.cancel()
            await asyncio.gather(*reads, return_exceptions=True)
            await busy
            assert await line.read(ReadSpeed(1)) == 300  # the line goes on
            assert sent == []
        finally:
            await line.stop()

    asyncio.run(main())
