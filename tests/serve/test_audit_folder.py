"""The audit log's folder: made when missing (a new machine has no state folder yet), private to
its user, and a folder that cannot be made is an AuditError that says where."""

from __future__ import annotations

import json
import stat
from pathlib import Path

import pytest

from robostar.serve import AuditError
from robostar.serve.audit import AuditLog


def test_a_missing_folder_is_made_private_and_the_log_written(tmp_path: Path) -> None:
    path = tmp_path / "state" / "robostar" / "audit.jsonl"
    log = AuditLog(path)
    log.ready()
    log.write(line="cell1", who="ann", face="api", what="CB speed 50 %", outcome="ok")
    log.close()
    assert stat.S_IMODE(path.parent.stat().st_mode) == 0o700
    entries = [json.loads(line) for line in path.read_text().splitlines()]
    assert entries[-1]["what"] == "CB speed 50 %"


def test_a_folder_that_cannot_be_made_is_an_audit_error(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(AuditError, match="file"):
        AuditLog(blocker / "audit.jsonl").open()
