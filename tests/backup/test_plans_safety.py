"""Backup and restore never lose data: atomic backups, generations, preflight, diff, confirm."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from robostar.client import Client
from robostar.errors import UsageError

from .conftest import AsJson, Run


def test_backup_refuses_a_foreign_folder(on: Run, tmp_path: Path) -> None:
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "notes.txt").write_text("precious")
    result = on("backup", str(folder))
    assert result.exit_code == 2
    assert "not a robostar backup" in result.stderr
    assert [p.name for p in folder.iterdir()] == ["notes.txt"]


def test_interrupted_backup_keeps_the_previous_one(tmp_path: Path) -> None:
    folder = tmp_path / "bk"
    with Client("sim://?speedup=50") as client:
        first = client.backup(folder)
        before = {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}
        client.upload_job(1, "NEW.JOB", ["MAIN", "EOP"])

        def interrupt(done: int, total: int | None) -> None:
            if done == 2:
                raise KeyboardInterrupt

        with pytest.raises(KeyboardInterrupt):
            client.backup(folder, progress=interrupt)
    after = {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    assert after == before and len(first.files) == 4
    assert [p.name for p in tmp_path.iterdir()] == ["bk"]  # no temporary folder left


def test_backup_replaces_a_previous_backup_whole(on: Run, tmp_path: Path, sim_line: Any) -> None:
    folder = tmp_path / "bk"
    assert on("backup", str(folder)).exit_code == 0
    on("files", "rm", "DEMO.JOB")
    assert on("backup", str(folder)).exit_code == 0
    assert not (folder / "ch1" / "DEMO.JOB").exists()
    assert (folder / "ch2" / "DEMO.JOB").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bk"]


def test_keep_generations(on: Run, as_json: AsJson, tmp_path: Path) -> None:
    for _ in range(3):
        assert as_json(on("--json", "backup", str(tmp_path / "gens"), "--keep", "2"))["ok"]
    generations = sorted(p.name for p in (tmp_path / "gens").iterdir())
    assert len(generations) == 2 and all(g.startswith("backup-") for g in generations)
    assert all((tmp_path / "gens" / g / "manifest.json").exists() for g in generations)


def _prepare(on: Run, tmp_path: Path) -> Path:
    folder = tmp_path / "bk"
    assert on("backup", str(folder)).exit_code == 0
    on("files", "rm", "DEMO.JOB")  # ch1/DEMO.JOB: new for the restore
    on("-c", "2", "files", "rm", "DEMO.JOB")
    job = tmp_path / "DEMO.JOB"
    job.write_text("MAIN\nEOP\n")
    on("-c", "2", "files", "put", str(job))  # ch2/DEMO.JOB: changed
    extra = tmp_path / "EXTRA.JOB"
    extra.write_text("MAIN\nEOP\n")
    on("files", "put", str(extra))  # ch1/EXTRA.JOB: not in the backup
    return folder


def test_restore_dry_run_prints_the_diff_and_writes_nothing(
    on: Run, as_json: AsJson, tmp_path: Path, sim_line: Any
) -> None:
    folder = _prepare(on, tmp_path)
    before = sim_line.jobs(), sim_line.jobs(2)
    data = as_json(on("--json", "restore", str(folder), "--dry-run", "--delete-extra"))
    assert data["dry_run"] is True and data["written"] is False
    diff = data["diff"]
    assert diff["new"] == ["ch1/DEMO.JOB"]
    assert diff["changed"] == ["ch2/DEMO.JOB"]
    assert diff["unchanged"] == ["ch1/DEMO.PNT", "ch2/DEMO.PNT"]
    assert diff["not_in_backup"] == ["ch1/EXTRA.JOB"]
    assert diff["would_be_deleted"] == ["ch1/EXTRA.JOB"]
    assert (sim_line.jobs(), sim_line.jobs(2)) == before
    human = on("restore", str(folder), "--dry-run")
    assert "would" not in human.stdout or "not in the backup" in human.stdout
    assert "1 new, 1 changed, 2 unchanged" in human.stdout


def test_restore_asks_and_no_writes_nothing(on: Run, tmp_path: Path, sim_line: Any) -> None:
    folder = _prepare(on, tmp_path)
    before = sim_line.jobs(), sim_line.jobs(2)
    result = on("restore", str(folder), input="n\n")
    assert result.exit_code == 1
    assert "Write 2 file change(s)" in result.stdout and "Nothing was written" in result.stdout
    assert (sim_line.jobs(), sim_line.jobs(2)) == before
    yes = on("restore", str(folder), input="y\n")
    assert yes.exit_code == 0, yes.output
    assert "DEMO.JOB" in sim_line.jobs() and "EXTRA.JOB" in sim_line.jobs()
    assert sim_line.jobs(2)["DEMO.JOB"] != ["MAIN", "EOP"]


def test_restore_channel_and_only(on: Run, as_json: AsJson, tmp_path: Path) -> None:
    folder = _prepare(on, tmp_path)
    data = as_json(on("--json", "restore", str(folder), "--channel", "2", "--yes"))
    assert data["diff"]["changed"] == ["ch2/DEMO.JOB"] and data["diff"]["new"] == []
    data = as_json(on("--json", "restore", str(folder), "--only", "*.PNT", "--dry-run"))
    assert data["diff"]["new"] == [] and data["diff"]["unchanged"] == [
        "ch1/DEMO.PNT",
        "ch2/DEMO.PNT",
    ]


def test_restore_refuses_another_controller(on: Run, tmp_path: Path, sim_line: Any) -> None:
    folder = _prepare(on, tmp_path)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["controller"]["version"] = "9.99"
    manifest["controller"]["channels"][0]["axes_in_use"] = [1, 2]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    before = sim_line.jobs(), sim_line.jobs(2)
    result = on("restore", str(folder), "--yes")
    assert result.exit_code == 2
    assert "version" in result.stderr and "axes" in result.stderr
    assert (sim_line.jobs(), sim_line.jobs(2)) == before
    forced = on("restore", str(folder), "--yes", "--ignore-identity")
    assert forced.exit_code == 0, forced.output


@pytest.mark.parametrize(
    ("field", "value", "words"),
    [
        ("path", "../../outside/DEMO.JOB", "path"),
        ("path", "/etc/passwd", "path"),
        ("name", "A B.JOB", "name"),
        ("name", "DEMO.TXT", "name"),
        ("channel", 7, "channel"),
        ("sha256", "x", "sha256"),
    ],
)
def test_restore_validates_the_whole_manifest_before_reading(
    tmp_path: Path, field: str, value: object, words: str
) -> None:
    folder = tmp_path / "bk"
    with Client("sim://?speedup=50") as client:
        client.backup(folder)
        manifest = json.loads((folder / "manifest.json").read_text())
        manifest["files"][-1][field] = value
        (folder / "manifest.json").write_text(json.dumps(manifest))
        # The first file is unreadable: a restore that read before validating would say so.
        (folder / "ch1" / "DEMO.JOB").chmod(0)
        (folder / "ch1").chmod(0)
        try:
            with pytest.raises(UsageError, match=words) as caught:
                client.restore(folder)
        finally:
            (folder / "ch1").chmod(0o755)
    assert "cannot read" not in str(caught.value)
