"""restore: a JOB file the controller holds under another job number is caught by the
preflight (nothing written), and a refusal that stops a restore part-way names the alarm it
left."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from robostar.sim.alarms import AlarmCode

from .conftest import Run, SimLine


def _renumbered(on: Run, sim_line: SimLine, tmp_path: Path) -> Path:
    """A backup holding AAA.JOB (11) and BBB.JOB (12); since then AAA.JOB was edited and
    BBB.JOB deleted and uploaded again as number 40."""
    a, b, a2 = tmp_path / "a.job", tmp_path / "b.job", tmp_path / "a2.job"
    a.write_text("MAIN\nEOP\n")
    b.write_text("MAIN\nWAIT 1\nEOP\n")
    a2.write_text("MAIN\nWAIT 2\nEOP\n")
    assert on("files", "put", str(a), "--name", "AAA.JOB", "--number", "11").exit_code == 0
    assert on("files", "put", str(b), "--name", "BBB.JOB", "--number", "12").exit_code == 0
    folder = tmp_path / "bk"
    assert on("backup", str(folder)).exit_code == 0
    assert on("files", "put", str(a2), "--name", "AAA.JOB").exit_code == 0
    assert on("files", "rm", "BBB.JOB").exit_code == 0
    assert on("files", "put", str(a2), "--name", "BBB.JOB", "--number", "40").exit_code == 0
    return folder


@pytest.mark.parametrize("mode", ["--yes", "--dry-run"])
def test_a_renumbered_job_is_refused_before_anything_is_written(
    on: Run, sim_line: SimLine, tmp_path: Path, mode: str
) -> None:
    folder = _renumbered(on, sim_line, tmp_path)
    before = sim_line.jobs()
    result = on("restore", str(folder), mode, "--only", "[AB]*")
    assert result.exit_code == 2, result.output
    assert "ch1/BBB.JOB is job number 40 on the controller, 12 in the backup" in result.stderr
    assert "nothing was written" in result.stderr and "files rm" in result.stderr
    assert sim_line.jobs() == before  # AAA.JOB was not written either
    assert json.loads(on("--json", "alarms").stdout)["alarms"] == []
    # The way out the message gives: delete it, then the restore writes it anew.
    assert on("files", "rm", "BBB.JOB").exit_code == 0
    again = on("restore", str(folder), "--yes", "--only", "[AB]*")
    assert again.exit_code == 0, again.output
    assert sim_line.jobs()["BBB.JOB"] == ["MAIN", "WAIT 1", "EOP"]
    assert sim_line.jobs()["AAA.JOB"] == ["MAIN", "EOP"]


def test_a_refusal_part_way_names_the_alarm_it_left(
    on: Run, sim_line: SimLine, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = _renumbered(on, sim_line, tmp_path)
    assert on("files", "rm", "BBB.JOB").exit_code == 0
    model = sim_line.controller.model
    check = model.check_upload

    def refuse_bbb(number: int, name: object, job_number: int) -> None:
        if str(name) == "BBB.JOB":  # refused with an alarm, as a controller may
            raise model._alarm_refusal(
                AlarmCode.RUN_FAIL, model.channel(number), "no room", f"FB {name}"
            )
        check(number, name, job_number)

    monkeypatch.setattr(model, "check_upload", refuse_bbb)
    result = on("--json", "restore", str(folder), "--yes", "--only", "[AB]*")
    assert result.exit_code == 3, result.output
    error = json.loads(result.stderr)["error"]
    assert error["restore"]["half_restored"] is True
    assert error["alarms_left"] == ["9002 : Run Fail"]
    human = on("restore", str(folder), "--yes", "--only", "[AB]*")
    assert human.exit_code == 3
    assert "left an alarm on the controller (9002 : Run Fail)" in human.stderr
