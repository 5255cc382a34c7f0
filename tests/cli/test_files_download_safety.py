"""`files get` never leaves a partial or empty file: non-ASCII content is a typed error."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from click.testing import Result

import robostar.commands.files as files_module
from robostar.protocol.fields import FileName
from robostar.sim.filesystem import StoredJob

Run = Callable[..., Result]
SimLine = Any


@pytest.fixture
def non_ascii_job(sim_line: SimLine, monkeypatch: pytest.MonkeyPatch) -> SimLine:
    # A controller that sends bytes outside ASCII in a job line (the simulator refuses to).
    original = files_module.encode_text

    def latin1(command: str, field: str, text: str, width: int) -> bytes:
        if command == "FA":
            return text.encode("latin-1")
        return original(command, field, text, width)

    monkeypatch.setattr(files_module, "encode_text", latin1)
    with sim_line.host.lock:
        files = sim_line.controller.model.channel(1).files
        files.put(StoredJob(FileName.parse("UMLT.JOB"), 7, ["MOVJ P1", "' Gr\xfc\xdfe"]))
    return sim_line


def test_non_ascii_download_is_a_typed_error_and_writes_nothing(
    non_ascii_job: SimLine, run: Run, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    result = run("--json", "files", "get", "UMLT.JOB", port=non_ascii_job.url)
    assert result.exit_code == 4, result.output
    assert '"MalformedAnswerError"' in result.stderr and "not ASCII" in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_failed_download_keeps_the_old_file(
    non_ascii_job: SimLine, run: Run, tmp_path: Path
) -> None:
    old = tmp_path / "old.JOB"
    old.write_text("KEEP ME\n")
    result = run("files", "get", "UMLT.JOB", str(old), "--force", port=non_ascii_job.url)
    assert result.exit_code == 4
    assert old.read_text() == "KEEP ME\n"
    assert [p.name for p in tmp_path.iterdir()] == ["old.JOB"]


def test_good_download_replaces_the_file_whole(run: Run, tmp_path: Path) -> None:
    target = tmp_path / "demo.JOB"
    target.write_text("OLD\n")
    result = run("files", "get", "DEMO.JOB", str(target), "--force")
    assert result.exit_code == 0, result.output
    assert "OLD" not in target.read_text()
    assert target.stat().st_size > 0
    assert [p.name for p in tmp_path.iterdir()] == ["demo.JOB"]


def test_unwritable_destination_is_a_usage_error(run: Run, tmp_path: Path) -> None:
    result = run("files", "get", "DEMO.JOB", str(tmp_path / "no" / "such" / "dir.JOB"))
    assert result.exit_code == 2
    assert "dest" in result.stderr.lower()


def test_xy_point_file_keeps_its_kind(run: Run, tmp_path: Path) -> None:
    saved = tmp_path / "DEMO.PNT"
    assert run("files", "get", "DEMO.PNT", str(saved), "--xy").exit_code == 0
    assert saved.read_text().splitlines()[0] == "#COORDS XY"
    trace = tmp_path / "t.jsonl"
    put = run("--trace", str(trace), "files", "put", str(saved))
    assert put.exit_code == 2
    assert "XY" in put.stderr and "degrees" in put.stderr
    lines = trace.read_text().splitlines() if trace.exists() else []
    sent = [line for line in lines if '"tx"' in line]
    assert not any('"FB"' in line for line in sent)
    angles = tmp_path / "angles" / "DEMO.PNT"
    angles.parent.mkdir()
    assert run("files", "get", "DEMO.PNT", str(angles)).exit_code == 0
    assert run("files", "put", str(angles)).exit_code == 0
