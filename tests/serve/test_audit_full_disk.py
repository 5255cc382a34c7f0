"""A full disk: the audit file opens for appending, only its writes fail (ENOSPC).

/dev/full is exactly that, so these tests use it as the audit path. Reopening the file is no
proof that the log can be written again; only a write that reaches it is.
"""

from __future__ import annotations

import asyncio
import json
import logging
from pathlib import Path

import pytest

from robostar.commands.control import EmergencyStop, ReadSpeed, SetSpeed
from robostar.serve import AuditError, Who
from robostar.serve.audit import AuditLog

from .conftest import sim_server

ANN = Who("ann", "api")
FULL = Path("/dev/full")

pytestmark = pytest.mark.skipif(not FULL.exists(), reason="needs /dev/full (Linux)")


def test_on_a_full_disk_state_changes_after_the_first_failed_write_are_refused(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.ERROR)

    async def main() -> tuple[list[str], int]:
        async with sim_server(poll_interval=0.5, audit_path=str(FULL)) as server:
            line = server.lines["cell1"]
            # carried out: its answer is not lost to the audit; the failed write is told
            await line.execute(SetSpeed(1, 100), who=ANN, implicit_lease=True)
            assert "No space left on device" in (server.audit.failure or "")
            outcomes = []
            for speed in (200, 300):
                try:
                    await line.execute(SetSpeed(1, speed), who=ANN, implicit_lease=True)
                    outcomes.append("carried out")
                except AuditError as exc:
                    outcomes.append(f"refused: {exc}")
            await line.execute(EmergencyStop(), who=ANN)  # a stop is never refused for it
            return outcomes, await line.read(ReadSpeed(1), max_age=0)

    outcomes, speed = asyncio.run(main())
    assert speed == 100, outcomes
    assert all(o.startswith("refused: audit log /dev/full") for o in outcomes), outcomes
    assert any("No space left on device" in o for o in outcomes), outcomes


def test_ready_clears_a_write_failure_only_once_a_record_is_written(tmp_path: Path) -> None:
    audit = AuditLog(FULL)
    audit.open()  # opening a full disk's file works ...
    assert audit.failure is None
    audit.write(line="cell1", who="ann", face="api", what="SetSpeed(1, 1)", outcome="ok")
    assert audit.failure is not None  # ... its writes do not
    with pytest.raises(AuditError, match="No space left on device"):
        audit.ready()
    audit.open()  # a reopen that works is no cure either
    assert audit.failure is not None
    with pytest.raises(AuditError):
        audit.ready()
    # the disk has room again (here: another path): the next ready() writes and clears
    audit.path = tmp_path / "audit.jsonl"
    audit.ready()
    assert audit.failure is None
    audit.write(line="cell1", who="ann", face="api", what="SetSpeed(1, 2)", outcome="ok")
    audit.close()
    records = [json.loads(x) for x in audit.path.read_text().splitlines()]
    assert records[0]["what"].startswith("audit log resumed after: /dev/full: No space left")
    assert records[1]["what"] == "SetSpeed(1, 2)"
