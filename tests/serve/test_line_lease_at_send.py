"""The lease is checked again just before a queued state change is sent: a requester that lost
the lease while its write waited behind a slow exchange has it refused, with nothing sent."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

from robostar.commands.control import EmergencyStop, ReadSpeed, SetSpeed
from robostar.serve import LineConfig, Who
from robostar.serve.audit import AuditLog
from robostar.serve.lease import LeaseHeldError
from robostar.serve.line import LeaseLostError, Line, WithdrawnError

from .line_fakes import FaultySim, hold_the_line, wait_for

ANN = Who("ann", "api")
BOB = Who("bob", "api")


async def _slow_line(sim: FaultySim, path: Path) -> Line:
    audit = AuditLog(path)
    audit.open()
    config = LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0)
    line = Line(config, client_factory=sim.client, audit=audit)
    await line.start()
    await line.wait_polled()
    return line


def test_a_write_queued_before_its_requester_lost_the_lease_is_refused_unsent(
    tmp_path: Path,
) -> None:
    sim = FaultySim()
    path = tmp_path / "audit.jsonl"

    async def main() -> None:
        line = await _slow_line(sim, path)
        try:
            busy = await hold_the_line(line, sim)
            ann = asyncio.create_task(line.execute(SetSpeed(1, 555), who=ANN, implicit_lease=True))
            assert await wait_for(lambda: line.lease.held_by(ANN))  # queued, with the lease
            line.lease.release(ANN)
            line.lease.acquire(BOB)  # bob takes control while ann's write waits
            with pytest.raises(LeaseLostError) as caught:
                await ann
            assert isinstance(caught.value, LeaseHeldError)  # faces answer it as a lease conflict
            text = str(caught.value)
            assert "lost before it was sent" in text and "nothing was sent" in text
            assert "bob (api)" in text
            await busy
            sim.write_delay = 0.0
            # bob's own writes go through as before
            await line.execute(SetSpeed(1, 60), who=BOB)
            assert await line.read(ReadSpeed(1), max_age=0) == 60
        finally:
            await line.stop()

    asyncio.run(main())
    assert [c.speed for c in sim.sent if isinstance(c, SetSpeed)] == [60]  # 555 never went out
    entries = [json.loads(raw) for raw in path.read_text().splitlines()]
    ann_entries = [e for e in entries if e["who"] == "ann"]
    assert len(ann_entries) == 1
    assert ann_entries[0]["outcome"].startswith("refused: ")
    assert "lost before it was sent" in ann_entries[0]["outcome"]


def test_a_write_queued_when_the_lease_expired_is_refused_unsent(tmp_path: Path) -> None:
    sim = FaultySim()

    async def main() -> None:
        line = await _slow_line(sim, tmp_path / "audit.jsonl")
        line.lease.ttl = 0.1  # expires while the write waits
        try:
            busy = await hold_the_line(line, sim)
            with pytest.raises(LeaseLostError, match="the lease is free"):
                await line.execute(SetSpeed(1, 556), who=ANN, implicit_lease=True)
            await busy
        finally:
            await line.stop()

    asyncio.run(main())
    assert not any(isinstance(c, SetSpeed) for c in sim.sent)


def test_a_stop_queued_by_someone_without_the_lease_still_goes_out(tmp_path: Path) -> None:
    sim = FaultySim()

    async def main() -> None:
        line = await _slow_line(sim, tmp_path / "audit.jsonl")
        try:
            busy = await hold_the_line(line, sim)
            line.lease.acquire(BOB)
            await line.execute(EmergencyStop(), who=ANN)  # stops need no lease
            await busy
        finally:
            await line.stop()

    asyncio.run(main())
    assert any(isinstance(c, EmergencyStop) for c in sim.sent)


def test_withdraw_takes_a_requesters_queued_requests_out_but_not_its_stops(
    tmp_path: Path,
) -> None:
    sim = FaultySim()
    path = tmp_path / "audit.jsonl"

    async def main() -> None:
        line = await _slow_line(sim, path)
        try:
            busy = await hold_the_line(line, sim)
            write = asyncio.create_task(
                line.execute(SetSpeed(1, 557), who=ANN, implicit_lease=True)
            )
            read = asyncio.create_task(line.read(ReadSpeed(3), max_age=0, who=ANN))
            stop = asyncio.create_task(line.execute(EmergencyStop(), who=ANN))
            other = asyncio.create_task(line.read(ReadSpeed(1), max_age=0, who=BOB))
            assert await wait_for(lambda: line.queue_depth == 5)
            assert line.withdraw(ANN, "ann went away") == 2
            with pytest.raises(WithdrawnError, match="ann went away"):
                await write
            with pytest.raises(WithdrawnError, match="nothing was sent"):
                await read
            await stop
            await other
            await busy
        finally:
            await line.stop()

    asyncio.run(main())
    assert not any(isinstance(c, SetSpeed) for c in sim.sent)
    assert not any(isinstance(c, ReadSpeed) and c.channel == 3 for c in sim.sent)
    assert any(isinstance(c, EmergencyStop) for c in sim.sent)
    entries = [json.loads(raw) for raw in path.read_text().splitlines()]
    (entry,) = [e for e in entries if "SetSpeed" in e["what"]]
    assert entry["outcome"].startswith("cancelled, not sent: ")
