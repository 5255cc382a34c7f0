"""`restore --only PATTERN` refuses, before anything is sent, a pattern that matches no file
of the backup (nor, with --delete-extra, of the controller), rather than restoring nothing and
reporting success; a pattern that matches still restores."""

from __future__ import annotations

import json
from pathlib import Path

from .conftest import Run, SimLine


def _backup_then_edit(on: Run, tmp_path: Path) -> Path:
    folder = tmp_path / "bk"
    assert on("backup", str(folder)).exit_code == 0
    job = tmp_path / "d.job"
    job.write_text("MAIN\nEOP\n")
    assert on("files", "put", str(job), "--name", "DEMO.JOB").exit_code == 0
    return folder


def test_a_pattern_matching_nothing_is_refused(on: Run, sim_line: SimLine, tmp_path: Path) -> None:
    folder = _backup_then_edit(on, tmp_path)
    result = on("restore", str(folder), "--only", "DEMO.JB", "--yes")
    assert result.exit_code == 2, result.output
    said = " ".join(result.stderr.split())
    assert "'DEMO.JB' matches no file of the backup" in said and "ch1/DEMO.JOB" in said
    as_json = on("--json", "restore", str(folder), "--only", "DEMO.JB", "--yes")
    assert as_json.exit_code == 2
    assert "DEMO.JB" in json.loads(as_json.stderr)["error"]["message"]
    on_channel = on("restore", str(folder), "--only", "DEMO.JOB", "-c", "3", "--yes")
    assert on_channel.exit_code == 2 and "on channel 3" in on_channel.stderr
    assert sim_line.jobs()["DEMO.JOB"] == ["MAIN", "EOP"]  # nothing written


def test_a_pattern_matching_a_file_still_restores_it(
    on: Run, sim_line: SimLine, tmp_path: Path
) -> None:
    folder = _backup_then_edit(on, tmp_path)
    result = on("restore", str(folder), "--only", "demo.j*", "-c", "1", "--yes")
    assert result.exit_code == 0, result.output
    assert "Restored 1 file change(s)" in result.stdout
    assert sim_line.jobs()["DEMO.JOB"] != ["MAIN", "EOP"]


def test_with_delete_extra_a_pattern_may_choose_the_controllers_files(
    on: Run, sim_line: SimLine, tmp_path: Path
) -> None:
    folder = _backup_then_edit(on, tmp_path)
    extra = tmp_path / "OLD.JOB"
    extra.write_text("MAIN\nEOP\n")
    assert on("files", "put", str(extra)).exit_code == 0
    result = on("restore", str(folder), "--only", "OLD*", "--delete-extra", "--yes")
    assert result.exit_code == 0, result.output
    assert "OLD.JOB" not in sim_line.jobs()
    nothing = on("restore", str(folder), "--only", "NOPE*", "--delete-extra", "--yes")
    assert nothing.exit_code == 2 and "'NOPE*' matches no file" in nothing.stderr
