"""The audit log when a requester goes away (a cancelled task: the N1 face draining at SIGTERM, an
MQTT or OPC UA task stopped): a write that may have reached the robot is never logged as a plain
error, and one that never left the queue says it was not sent."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from robostar.commands.control import ReadSpeed, SetSpeed
from robostar.protocol.frame import encode_packet
from robostar.serve import LineConfig, LineServer, ServeConfig, Who
from robostar.serve.audit import AuditLog
from robostar.serve.line import Line

from .line_fakes import FaultySim, wait_for

HOST = Who("host", "n1")


def _entries(path: Path, what: str) -> list[dict[str, Any]]:
    return [e for e in map(json.loads, path.read_text().splitlines()) if what in e["what"]]


def _slow_line(sim: FaultySim, path: Path) -> Line:
    audit = AuditLog(path)
    audit.open()
    config = LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0)
    return Line(config, client_factory=sim.client, audit=audit)


def test_a_write_whose_requester_goes_away_on_the_wire_is_audited_as_outcome_unknown(
    tmp_path: Path,
) -> None:
    sim = FaultySim()
    path = tmp_path / "audit.jsonl"

    async def main() -> int:
        line = _slow_line(sim, path)
        await line.start()
        try:
            await line.wait_polled()
            sim.write_delay = 0.3
            task = asyncio.create_task(
                line.execute(SetSpeed(1, 777), who=HOST, implicit_lease=True)
            )
            assert await wait_for(
                lambda: line._current is not None and isinstance(line._current.command, SetSpeed)
            )
            task.cancel()
            with pytest.raises(asyncio.CancelledError):  # the cancellation goes on to the caller
                await task
            # the worker ends the exchange
            assert await wait_for(
                lambda: line._current is None or not isinstance(line._current.command, SetSpeed)
            )
            sim.write_delay = 0.0
            return await line.read(ReadSpeed(1), max_age=0)
        finally:
            await line.stop()

    assert asyncio.run(main()) == 777  # the robot carried it out
    outcomes = [e["outcome"] for e in _entries(path, "SetSpeed")]
    assert outcomes == ["outcome unknown: the requester went away while it was on the wire"]


def test_a_write_whose_requester_goes_away_in_the_queue_is_audited_as_not_sent(
    tmp_path: Path,
) -> None:
    sim = FaultySim()
    path = tmp_path / "audit.jsonl"

    async def main() -> int:
        line = _slow_line(sim, path)
        await line.start()
        try:
            await line.wait_polled()
            sim.write_delay = 0.3
            read = ReadSpeed(2)
            busy = asyncio.create_task(line.read(read, max_age=0))
            assert await wait_for(
                lambda: line._current is not None and line._current.command is read
            )
            task = asyncio.create_task(
                line.execute(SetSpeed(1, 778), who=HOST, implicit_lease=True)
            )
            # the lease is taken as the write is queued: it now waits behind the read on the wire
            assert await wait_for(lambda: line.lease.held_by(HOST))
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            await busy
            sim.write_delay = 0.0
            return await line.read(ReadSpeed(1), max_age=0)
        finally:
            await line.stop()

    assert asyncio.run(main()) != 778
    assert not any(isinstance(c, SetSpeed) for c in sim.sent)
    outcomes = [e["outcome"] for e in _entries(path, "SetSpeed")]
    assert outcomes == ["cancelled, not sent"]


def test_stopping_the_server_during_an_n1_write_on_the_wire_audits_outcome_unknown(
    tmp_path: Path,
) -> None:
    sim = FaultySim()
    path = tmp_path / "audit.jsonl"

    async def main() -> None:
        config = ServeConfig(
            lines=(LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0),),
            faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
            audit_path=str(path),
        )
        server = LineServer(config, client_factory=sim.client)
        await server.start()
        try:
            host, port = server.faces["n1"].addresses["cell1"]
            line = server.lines["cell1"]
            sim.write_delay = 0.5
            _, writer = await asyncio.open_connection(host, port)
            writer.write(encode_packet(SetSpeed(1, 616).encode()))
            await writer.drain()
            assert await wait_for(
                lambda: line._current is not None and isinstance(line._current.command, SetSpeed)
            )
        finally:
            await server.stop()  # SIGTERM: the N1 face drains (cancels) first
        writer.close()

    asyncio.run(main())
    outcomes = [e["outcome"] for e in _entries(path, "SetSpeed")]
    assert outcomes == ["outcome unknown: the requester went away while it was on the wire"]
