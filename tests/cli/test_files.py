"""`files`, `backup` and `restore` against a served simulator."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .conftest import AsJson, Run

JOB = ["MAIN", "JMOV P1", "OUT 0,2,1", "EOP"]


def names(on: Run, as_json: AsJson, channel: str = "1") -> list[str]:
    return [f["name"] for f in as_json(on("--json", "-c", channel, "files", "ls"))["files"]]


def test_ls(on: Run, as_json: AsJson) -> None:
    data = as_json(on("--json", "files", "ls"))
    assert data["channel"] == 1
    demo = {f["name"]: f for f in data["files"]}
    assert demo["DEMO.JOB"]["job_number"] == 1
    assert demo["DEMO.JOB"]["steps"] == 8
    human = on("files", "ls").stdout
    assert "DEMO.JOB" in human and "DEMO.PNT" in human and "steps" in human
    one = as_json(on("--json", "files", "ls", "DEMO.JOB"))
    assert [f["name"] for f in one["files"]] == ["DEMO.JOB"]


def test_get_put_round_trip(on: Run, as_json: AsJson, tmp_path: Path) -> None:
    job = tmp_path / "demo.job"
    saved = as_json(on("--json", "files", "get", "DEMO.JOB", str(job)))
    assert saved["lines"] == 8
    assert job.read_text().splitlines()[0] == "MAIN"
    points = tmp_path / "DEMO.PNT"
    assert on("files", "get", "DEMO.PNT", str(points)).exit_code == 0
    assert points.read_text().startswith("P0001")
    refused = on("files", "get", "DEMO.JOB", str(job))
    assert refused.exit_code == 2 and "--force" in refused.stderr
    assert on("files", "get", "DEMO.JOB", str(job), "--force").exit_code == 0

    mine = tmp_path / "mine.job"
    mine.write_text("\n".join(JOB) + "\n")
    put = on("files", "put", str(mine), "--name", "MINE.JOB")
    assert put.exit_code == 0, put.output
    assert "reads back the same" in put.stdout
    assert "MINE.JOB" in names(on, as_json)
    back = on("files", "get", "MINE.JOB", "-")
    assert back.stdout.splitlines() == JOB
    assert as_json(on("--json", "files", "get", "MINE.JOB", "-"))["lines"] == JOB

    as_json(on("--json", "files", "put", str(points), "--name", "MINE.PNT"))
    assert on("files", "get", "MINE.PNT", "-").stdout == points.read_text()
    xy = on("files", "get", "MINE.PNT", "-", "--xy").stdout
    assert xy.startswith("#COORDS XY\nP0001") and xy != points.read_text()


def test_put_checks_the_file_before_sending(on: Run, tmp_path: Path) -> None:
    bad = tmp_path / "bad.pnt"
    bad.write_text("not a point line\n")
    result = on("files", "put", str(bad), "--name", "BAD.PNT")
    assert result.exit_code == 2
    mixed = tmp_path / "x.job"
    mixed.write_text("MAIN\nEOP\n")
    assert on("files", "put", str(mixed), "--name", "MiXed.JOB").exit_code == 2
    assert on("files", "put", str(mixed), "--name", "TOOLONG.JOB").exit_code == 2


def test_cp_mv_rm(on: Run, as_json: AsJson) -> None:
    assert as_json(on("--json", "files", "cp", "DEMO.JOB", "COPY.JOB"))["new_name"] == "COPY.JOB"
    assert "COPY.JOB" in names(on, as_json)
    assert "Renamed COPY.JOB to NEW.JOB." in on("files", "mv", "COPY.JOB", "NEW.JOB").stdout
    assert "NEW.JOB" in names(on, as_json) and "COPY.JOB" not in names(on, as_json)
    assert "Deleted NEW.JOB." in on("files", "rm", "NEW.JOB").stdout
    assert "NEW.JOB" not in names(on, as_json)
    refused = on("files", "rm", "DEMO.PNT")
    assert refused.exit_code == 3


def test_backup_and_restore(on: Run, as_json: AsJson, tmp_path: Path, sim_line: Any) -> None:
    folder = tmp_path / "backup"
    human = on("backup", str(folder))
    assert human.exit_code == 0, human.output
    assert "manifest" in human.stdout
    manifest = json.loads((folder / "manifest.json").read_text())
    saved = {(f["channel"], f["name"]) for f in manifest["files"]}
    assert (1, "DEMO.JOB") in saved and (2, "DEMO.PNT") in saved

    on("files", "rm", "DEMO.JOB")
    assert "DEMO.JOB" not in names(on, as_json)
    data = as_json(on("--json", "restore", str(folder), "--yes"))
    assert data["written"] is True and data["diff"]["new"] == ["ch1/DEMO.JOB"]
    assert "DEMO.JOB" in names(on, as_json)
    again = on("restore", str(folder))  # nothing differs now: no question, nothing written
    assert again.exit_code == 0, again.output
    assert "0 new, 0 changed, 4 unchanged" in again.stdout

    second = tmp_path / "second"
    assert as_json(on("--json", "backup", str(second)))["ok"] is True
