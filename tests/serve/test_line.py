"""The line server's core against the simulator: model, reads, lease, audit, queue order."""

from __future__ import annotations

import asyncio
import json
import time
from pathlib import Path

import pytest

from robostar.commands.control import EmergencyStop, ReadSpeed, SetSpeed
from robostar.commands.status import ReadStatus
from robostar.errors import UsageError
from robostar.serve import (
    AuditError,
    LeaseHeldError,
    LineBusyError,
    LineConfig,
    LineServer,
    Quality,
    ServeConfig,
    Who,
)
from robostar.serve.line import MAX_QUEUED_READS, stale_after

from .conftest import sim_server

ALICE = Who("alice", "api")
BOB = Who("bob", "n1")


def test_the_poller_fills_the_model_with_stamped_values() -> None:
    async def main() -> None:
        async with sim_server() as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            snap = line.model.snapshot()
            for key in (
                "online",
                "info",
                "alarms",
                "ch1/status",
                "ch1/position",
                "ch1/angles",
                "ch1/speed",
                "ch1/job",
                "ch1/step",
                "io/in/0",
                "io/out/0",
                "alarm_history",
            ):
                assert key in snap, key
                assert snap[key].quality is Quality.GOOD
            assert snap["online"].value is True
            assert snap["ch1/speed"].value == 300

    asyncio.run(main())


def test_a_read_after_a_write_sees_the_write() -> None:
    async def main() -> None:
        async with sim_server(poll_interval=5.0) as server:
            line = server.lines["cell1"]
            assert await line.read(ReadSpeed(1)) == 300
            await line.execute(SetSpeed(1, 42), who=ALICE, implicit_lease=True)
            # the model still holds 300 (the poller is slow) but the write invalidated it
            assert await line.read(ReadSpeed(1), max_age=60) == 42

    asyncio.run(main())


def test_fresh_reads_come_from_the_model_without_an_exchange() -> None:
    async def main() -> None:
        async with sim_server(poll_interval=5.0) as server:
            line = server.lines["cell1"]
            await line.read(ReadStatus())
            before = line.health.exchanges
            for _ in range(20):
                await line.read(ReadStatus(), max_age=60)
            assert line.health.exchanges == before

    asyncio.run(main())


def test_the_lease_has_one_holder_and_names_it(tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with sim_server(audit_path=str(audit)) as server:
            line = server.lines["cell1"]
            with pytest.raises(LeaseHeldError):
                await line.execute(SetSpeed(1, 10), who=ALICE)  # no implicit lease: refused
            await line.execute(SetSpeed(1, 10), who=ALICE, lease="hold")
            with pytest.raises(LeaseHeldError, match="alice"):
                await line.execute(SetSpeed(1, 20), who=BOB, implicit_lease=True)
            # a stop needs no lease
            await line.execute(EmergencyStop(), who=BOB)
            assert line.lease.release(ALICE)
            await line.execute(SetSpeed(1, 30), who=BOB, lease="hold")
            holder = line.lease.holder
            assert holder is not None and holder.who == BOB

    asyncio.run(main())
    records = [json.loads(x) for x in audit.read_text().splitlines()]
    outcomes = [(r["who"], r["what"].split("(")[0], r["outcome"].split(":")[0]) for r in records]
    assert outcomes == [
        ("alice", "SetSpeed", "refused"),
        ("alice", "SetSpeed", "ok"),
        ("bob", "SetSpeed", "refused"),
        ("bob", "EmergencyStop", "ok"),
        ("bob", "SetSpeed", "ok"),
    ]
    assert all(r["line"] == "cell1" and r["at"] > 0 for r in records)


def test_a_write_through_read_is_refused() -> None:
    async def main() -> None:
        async with sim_server() as server:
            with pytest.raises(UsageError):
                await server.lines["cell1"].read(SetSpeed(1, 5))

    asyncio.run(main())


def test_a_slow_subscriber_never_blocks_and_counts_drops() -> None:
    async def main() -> None:
        async with sim_server() as server:
            line = server.lines["cell1"]
            sub = line.model.subscribe(maxsize=3)
            fast = line.model.subscribe()
            await line.wait_polled()
            await line.wait_polled()
            # the slow one never read: it holds at most 3 changes and counted what it lost
            assert sub.pending() == 3
            assert sub.dropped > 0
            first = await anext(fast)
            assert first.line == "cell1"
            sub.close()
            fast.close()
            assert line.model.subscribers == 0

    asyncio.run(main())


def test_two_lines_in_one_server_are_independent() -> None:
    async def main() -> None:
        async with sim_server("a", "b") as server:
            assert isinstance(server, LineServer)
            a, b = server.lines["a"], server.lines["b"]
            await a.execute(SetSpeed(1, 11), who=ALICE, implicit_lease=True)
            await b.execute(SetSpeed(1, 22), who=BOB, implicit_lease=True)
            assert await a.read(ReadSpeed(1), max_age=0) == 11
            assert await b.read(ReadSpeed(1), max_age=0) == 22

    asyncio.run(main())


def test_a_holder_that_goes_away_has_its_jog_stopped(tmp_path: Path) -> None:
    from robostar.commands.motion import JogStart
    from robostar.types import JogDirection, MotionType

    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with sim_server(audit_path=str(audit)) as server:
            line = server.lines["cell1"]
            jog = JogStart(1, 1, JogDirection.PLUS, MotionType.JOINT)
            await line.execute(jog, who=ALICE, implicit_lease=True)
            assert line.lease.release(ALICE)
            async with asyncio.timeout(5):  # written once the controller answered the BG
                while "lease lost" not in audit.read_text():
                    await asyncio.sleep(0.01)

    asyncio.run(main())
    records = [json.loads(x) for x in audit.read_text().splitlines()]
    assert [r["what"].split("(")[0] for r in records] == ["JogStart", "JogStop"]
    assert records[1]["outcome"] == "jog stopped: lease lost"


def test_a_write_wakes_the_poller_so_subscribers_see_it_at_once() -> None:
    async def main() -> None:
        async with sim_server(poll_interval=30.0) as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            with line.model.subscribe() as changes:
                await line.execute(SetSpeed(1, 123), who=ALICE, implicit_lease=True)
                async with asyncio.timeout(5):  # far below the 30 s poll interval
                    async for change in changes:
                        if change.key == "ch1/speed" and change.sample.value == 123:
                            break

    asyncio.run(main())


def test_an_audit_log_that_cannot_be_opened_stops_the_start(tmp_path: Path) -> None:
    async def main() -> None:
        with pytest.raises(AuditError, match="No such file or directory"):
            async with sim_server(audit_path=str(tmp_path / "missing" / "audit.jsonl")):
                pass

    asyncio.run(main())


class _FullDisk:
    """A file whose writes fail as on a full disk, until ``full`` is cleared."""

    def __init__(self) -> None:
        self.full = True
        self.lines: list[str] = []

    def write(self, text: str) -> int:
        if self.full:
            raise OSError(28, "No space left on device")
        self.lines.append(text)
        return len(text)

    def flush(self) -> None: ...

    def close(self) -> None: ...


def test_a_failed_audit_write_is_told_and_refuses_what_follows_but_not_stops(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    async def main() -> None:
        async with sim_server(audit_path=str(tmp_path / "audit.jsonl")) as server:
            line = server.lines["cell1"]
            disk = _FullDisk()
            server.audit._file = disk  # type: ignore[assignment]
            # carried out: its answer is not lost to the audit (a retry would be a second copy)
            await line.execute(SetSpeed(1, 44), who=ALICE, implicit_lease=True)
            assert await line.read(ReadSpeed(1), max_age=0) == 44
            assert "No space left on device" in (server.audit.failure or "")
            assert any('"what": "SetSpeed' in r.getMessage() for r in caplog.records)
            # what follows is refused before the wire while the log cannot be written
            server.audit.path = tmp_path / "missing" / "audit.jsonl"
            with pytest.raises(AuditError, match="audit log"):
                await line.execute(SetSpeed(1, 55), who=ALICE, implicit_lease=True)
            assert await line.read(ReadSpeed(1), max_age=0) == 44
            await line.execute(EmergencyStop(), who=BOB)  # a stop is never refused for it
            # writable again: the log reopens and state changes pass
            server.audit.path = tmp_path / "audit.jsonl"
            await line.execute(SetSpeed(1, 66), who=ALICE, implicit_lease=True)
            assert server.audit.failure is None

    asyncio.run(main())
    records = [json.loads(x) for x in (tmp_path / "audit.jsonl").read_text().splitlines()]
    assert [r["what"].split("(")[0] for r in records][-1] == "SetSpeed"
    assert records[-1]["outcome"] == "ok"


def _flooded_line(**config: float) -> LineServer:
    line = LineConfig("cell1", "sim://", poll_interval=0.05, slow_interval=0.1, **config)
    return LineServer(ServeConfig(lines=(line,), faces={}))


def test_no_number_of_readers_can_starve_the_poller() -> None:
    async def main() -> None:
        async with _flooded_line() as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            stop = asyncio.Event()

            async def reader() -> None:
                while not stop.is_set():
                    await line.read(ReadSpeed(1), max_age=0)

            readers = [asyncio.create_task(reader()) for _ in range(40)]
            await asyncio.sleep(0.3)  # the queue always holds reads from here on
            flooded = time.time()
            await asyncio.sleep(1.5)
            stop.set()
            await asyncio.gather(*readers)
            # polls waited at most about stale_after (0.25 s here), then went first
            assert line.health.last_poll is not None and line.health.last_poll > flooded

    asyncio.run(main())


def test_values_nobody_refreshes_are_marked_stale(monkeypatch: pytest.MonkeyPatch) -> None:
    async def main() -> None:
        async with _flooded_line() as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            assert line.model.get("ch1/status").quality is Quality.GOOD  # type: ignore[union-attr]
            stuck = asyncio.Event()

            async def hang(command: object) -> None:
                await stuck.wait()

            monkeypatch.setattr(line.poller, "_poll_one", hang)  # a poller that never gets through
            limit = stale_after(line.config)
            async with asyncio.timeout(limit + 5):
                while line.model.get("ch1/status").quality is not Quality.STALE:  # type: ignore[union-attr]
                    await asyncio.sleep(0.02)
            assert line.health.poll_age is not None and line.health.poll_age > limit
            assert line.model.get("info").quality is Quality.GOOD  # type: ignore[union-attr]
            stuck.set()

    asyncio.run(main())


def test_a_read_past_the_queue_bound_is_refused_before_the_wire() -> None:
    async def main() -> None:
        async with _flooded_line() as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            sent = line.health.exchanges
            results = await asyncio.gather(
                *(line.read(ReadSpeed(1), max_age=0) for _ in range(MAX_QUEUED_READS + 100)),
                return_exceptions=True,
            )
            busy = [r for r in results if isinstance(r, LineBusyError)]
            assert len(busy) >= 50 and "reads are waiting" in str(busy[0])
            assert all(isinstance(r, int | LineBusyError) for r in results)
            assert line.health.exchanges - sent < MAX_QUEUED_READS + 50  # not sent
            assert await line.read(ReadSpeed(1), max_age=0) >= 0  # and serving again

    asyncio.run(main())
