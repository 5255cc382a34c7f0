"""A restore that fails or is interrupted after its first write says exactly where it left
the controller: the files written and verified, the one in doubt and those not touched (the
console's message, its --json, and the client's RestoreIncompleteError / RestoreInterrupted);
running the restore again finishes it."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from robostar import backup
from robostar.client import Client, sync
from robostar.commands.files import UploadFile
from robostar.errors import UploadIncompleteError

from .conftest import AsJson, Run


def _change_every_job(folder: Path) -> None:
    """Give every JOB file of the backup one more step (before EOP), manifest updated: a
    restore then has two changed files to write, ch1/DEMO.JOB and ch2/DEMO.JOB."""
    manifest = json.loads((folder / "manifest.json").read_text())
    for entry in manifest["files"]:
        path = folder / entry["path"]
        if path.suffix == ".JOB":
            lines = path.read_text().split("\n")
            lines = [*lines[:-2], lines[-3], *lines[-2:]]
            path.write_text("\n".join(lines))
        data = path.read_bytes()
        entry["bytes"] = len(data)
        entry["sha256"] = hashlib.sha256(data).hexdigest()
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=2))


@pytest.fixture
def second_upload_fails(monkeypatch: pytest.MonkeyPatch) -> Callable[[BaseException], None]:
    """Make the second FB of the run raise ``error`` (the first goes through)."""

    def arm(error: BaseException) -> None:
        original = sync.Client._call
        count = {"uploads": 0}

        def call(self: Any, command: Any, progress: Any = None, *, urgent: bool = False) -> Any:
            if isinstance(command, UploadFile):
                count["uploads"] += 1
                if count["uploads"] == 2:
                    raise error
            return original(self, command, progress, urgent=urgent)

        monkeypatch.setattr(sync.Client, "_call", call)

    return arm


@pytest.fixture
def changed_backup(on: Run, tmp_path: Path) -> Path:
    folder = tmp_path / "bk"
    assert on("backup", str(folder)).exit_code == 0
    _change_every_job(folder)
    return folder


def test_a_failed_restore_says_the_controller_is_half_restored(
    on: Run, changed_backup: Path, sim_line: Any, second_upload_fails: Any
) -> None:
    second_upload_fails(UploadIncompleteError("FB DEMO.JOB: the line was lost: injected"))
    result = on("restore", str(changed_backup), "--yes")
    assert result.exit_code == 4, result.output
    said = " ".join(result.stderr.split())
    assert "half-restored" in said
    assert "written and verified: ch1/DEMO.JOB" in said
    assert "in doubt: ch2/DEMO.JOB" in said and "the line was lost: injected" in said
    assert "not touched: none" in said
    assert "Run the same restore again" in said
    # What the message says is what happened: ch1 already holds the backup's version.
    assert len(sim_line.jobs(1)["DEMO.JOB"]) == len(sim_line.jobs(2)["DEMO.JOB"]) + 1


def test_a_failed_restore_in_json_carries_the_partial_state(
    on: Run, changed_backup: Path, second_upload_fails: Any
) -> None:
    second_upload_fails(UploadIncompleteError("FB DEMO.JOB: the line was lost: injected"))
    result = on("--json", "restore", str(changed_backup), "--yes")
    assert result.exit_code == 4
    error = json.loads(result.stderr)["error"]
    assert error["type"] == "RestoreIncompleteError"
    restore = error["restore"]
    assert restore["half_restored"] is True
    assert restore["verified"] == ["ch1/DEMO.JOB"]
    assert restore["in_doubt"] == "ch2/DEMO.JOB"
    assert restore["not_touched"] == []
    assert "restore again" in restore["hint"]


def test_running_the_restore_again_finishes_it(
    on: Run, as_json: AsJson, changed_backup: Path, second_upload_fails: Any, monkeypatch: Any
) -> None:
    second_upload_fails(UploadIncompleteError("FB DEMO.JOB: the line was lost: injected"))
    assert on("restore", str(changed_backup), "--yes").exit_code == 4
    monkeypatch.undo()
    data = as_json(on("--json", "restore", str(changed_backup), "--yes"))
    assert data["diff"]["changed"] == ["ch2/DEMO.JOB"]  # ch1 was done and verified


def test_ctrl_c_during_a_restore_says_the_controller_is_half_restored(
    on: Run, changed_backup: Path, second_upload_fails: Any
) -> None:
    second_upload_fails(KeyboardInterrupt())
    result = on("restore", str(changed_backup), "--yes")
    assert result.exit_code == 130
    said = " ".join(result.stderr.split())
    assert "Error: Interrupted: the restore of" in said
    assert "written and verified: ch1/DEMO.JOB" in said
    assert "in doubt: ch2/DEMO.JOB (FB DEMO.JOB aborted after 0/" in said
    assert "Run the same restore again" in said
    json_run = on("--json", "restore", str(changed_backup), "--yes")
    # (the injected failure is spent: this run completes ch2)
    assert json_run.exit_code == 0, json_run.output


def test_ctrl_c_during_a_restore_in_json(
    on: Run, changed_backup: Path, second_upload_fails: Any
) -> None:
    second_upload_fails(KeyboardInterrupt())
    result = on("--json", "restore", str(changed_backup), "--yes")
    assert result.exit_code == 130
    error = json.loads(result.stderr)["error"]
    assert error["type"] == "KeyboardInterrupt"
    assert error["restore"]["verified"] == ["ch1/DEMO.JOB"]
    assert error["restore"]["in_doubt"] == "ch2/DEMO.JOB"


def test_the_client_raises_the_restore_errors_with_their_state(
    tmp_path: Path, second_upload_fails: Any
) -> None:
    folder = tmp_path / "bk"
    with Client("sim://?speedup=50") as client:
        client.backup(folder)
        _change_every_job(folder)
        client.upload_job(1, "EXTRA.JOB", ["MAIN", "EOP"])
        second_upload_fails(UploadIncompleteError("injected"))
        with pytest.raises(backup.RestoreIncompleteError) as failed:
            client.restore(folder, delete_extra=True)
        state = failed.value.state
        assert state.verified == ("ch1/DEMO.JOB",) and state.in_doubt == "ch2/DEMO.JOB"
        assert state.untouched == ("ch1/EXTRA.JOB",)  # the deletion it did not reach
        assert isinstance(failed.value.__cause__, UploadIncompleteError)
        assert client.list_files(1, "EXTRA.JOB")  # not deleted


def test_restore_interrupted_is_still_a_keyboard_interrupt(
    tmp_path: Path, second_upload_fails: Any
) -> None:
    folder = tmp_path / "bk"
    with Client("sim://?speedup=50") as client:
        client.backup(folder)
        _change_every_job(folder)
        second_upload_fails(KeyboardInterrupt())
        with pytest.raises(KeyboardInterrupt) as caught:
            client.restore(folder)
    assert isinstance(caught.value, backup.RestoreInterrupted)
    assert caught.value.state.in_doubt == "ch2/DEMO.JOB"


def test_ctrl_c_between_two_files_leaves_none_in_doubt(tmp_path: Path) -> None:
    folder = tmp_path / "bk"

    def interrupt(done: int, total: int | None) -> None:
        if done == 2:  # ch1/DEMO.JOB written and read back the same
            raise KeyboardInterrupt

    with Client("sim://?speedup=50") as client:
        client.backup(folder)
        _change_every_job(folder)
        with pytest.raises(backup.RestoreInterrupted) as caught:
            client.restore(folder, progress=interrupt)
    state = caught.value.state
    assert state.verified == ("ch1/DEMO.JOB",) and state.in_doubt == ""
    assert state.untouched == ("ch2/DEMO.JOB",)
    assert "in doubt: none; not touched: ch2/DEMO.JOB" in str(caught.value)
