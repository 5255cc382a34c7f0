"""Backups and restores that go wrong part-way say exactly where they left things.

A restore that fails or is interrupted after its first write names the files written and
verified, the one in doubt and those not touched; a backup that cannot be written on this
computer says so (not "check the cable"); --keep never deletes the backup it just made; a
temporary folder left by a killed backup does not block the next one.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import shutil
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from robostar.client import Client, backup, sync
from robostar.client.backup import Manifest
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


# -- the manifest records the target ---------------------------------------------------------


def test_the_manifest_records_the_target_and_whether_it_is_a_simulator(
    on: Run, run: Run, tmp_path: Path, sim_line: Any
) -> None:
    served = tmp_path / "served"
    assert on("backup", str(served)).exit_code == 0
    data = json.loads((served / "manifest.json").read_text())
    assert data["target"] == sim_line.url and data["simulator"] is True  # N1-SIM answers AD
    # A simulator renamed to look like a robot is still one when the URL says sim://.
    port = "sim://?name=LINE3&version=N1RO%2003.02.05"
    renamed = tmp_path / "renamed"
    assert run("backup", str(renamed), port=port).exit_code == 0
    data = json.loads((renamed / "manifest.json").read_text())
    assert data["controller"]["name"] == "LINE3"
    assert data["target"] == port and data["simulator"] is True


def test_a_manifest_without_target_is_still_read(on: Run, as_json: AsJson, tmp_path: Path) -> None:
    folder = tmp_path / "old"
    assert on("backup", str(folder)).exit_code == 0
    data = json.loads((folder / "manifest.json").read_text())
    del data["target"], data["simulator"]
    (folder / "manifest.json").write_text(json.dumps(data))
    manifest = Manifest.from_json((folder / "manifest.json").read_text())
    assert manifest.target is None and manifest.simulator is None
    assert as_json(on("--json", "restore", str(folder), "--dry-run"))["ok"] is True


# -- a backup that cannot be written here ----------------------------------------------------

_FULL_DISK = textwrap.dedent(
    """
    import resource, signal, sys
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (64, 64))
    from robostar.cli.app import main
    main(sys.argv[1:])
    """
)


def _backup_on_a_full_disk(*args: str) -> tuple[int, str]:
    """`robostar --port sim:// backup ARGS` in a process whose disk is full: its exit code and
    its stderr on one line."""
    env = {k: v for k, v in os.environ.items() if k != "ROBOSTAR_PORT"}
    done = subprocess.run(
        [sys.executable, "-c", _FULL_DISK, "--port", "sim://", "backup", *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    return done.returncode, " ".join(done.stderr.split())


def test_a_backup_that_cannot_be_written_is_not_called_a_cable_fault(tmp_path: Path) -> None:
    folder = tmp_path / "bk"
    with Client("sim://?speedup=50") as client:
        client.backup(folder)
    before = {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    code, said = _backup_on_a_full_disk(str(folder))
    assert code == 2, said
    assert f"cannot write the backup at '{folder}'" in said.lower()
    assert "the previous backup is intact" in said
    assert "cable" not in said and "port failed" not in said.lower()
    after = {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    assert after == before
    assert [p.name for p in tmp_path.iterdir()] == ["bk"]  # no temporary folder left

    generations = tmp_path / "gens"
    with Client("sim://?speedup=50") as client:
        client.backup(generations, keep=2)
    (first,) = list(generations.iterdir())
    code, said = _backup_on_a_full_disk(str(generations), "--keep", "2")
    assert code == 2, said
    assert "the previous backups in the folder are intact" in said
    assert list(generations.iterdir()) == [first]


@pytest.mark.parametrize(
    ("error", "code", "words"),
    [
        (OSError(errno.ENOSPC, "No space left on device", "/data/x"), 2, "local file /data/x"),
        (OSError(errno.EACCES, "Permission denied"), 2, "local file"),
        (OSError(errno.EIO, "Input/output error"), 4, "The port failed"),
    ],
)
def test_only_port_errors_are_called_port_errors(
    run: Run, monkeypatch: pytest.MonkeyPatch, error: OSError, code: int, words: str
) -> None:
    from robostar.cli.session import ConsoleSession

    def send(self: ConsoleSession, command: Any) -> Any:
        raise error

    monkeypatch.setattr(ConsoleSession, "send", send)
    result = run("files", "rm", "OLD.JOB")
    assert result.exit_code == code
    assert words in result.stderr
    assert ("cable" in result.stderr) is (code == 4)


# -- --keep ----------------------------------------------------------------------------------


def _generation(root: Path, name: str, created: str, source: Path) -> Path:
    """A copy of the backup ``source`` as generation ``name`` with ``created`` in its manifest."""
    target = root / name
    shutil.copytree(source, target)
    data = json.loads((target / "manifest.json").read_text())
    data["created"] = created
    (target / "manifest.json").write_text(json.dumps(data))
    return target


def test_keep_never_deletes_the_backup_just_made(on: Run, as_json: AsJson, tmp_path: Path) -> None:
    source = tmp_path / "source"
    assert on("backup", str(source)).exit_code == 0
    root = tmp_path / "gens"
    root.mkdir()
    # A folder name from the future (a clock that was wrong), made long ago.
    _generation(root, "backup-20991231T000000000000Z", "2020-01-01T00:00:00+00:00", source)
    data = as_json(on("--json", "backup", str(root), "--keep", "1"))
    new = Path(data["path"])
    assert new.parent == root and new.name.startswith("backup-")
    assert [p.name for p in root.iterdir()] == [new.name]
    assert (new / "manifest.json").exists()
    human = on("backup", str(root), "--keep", "1")
    assert human.exit_code == 0
    (only,) = list(root.iterdir())
    assert only.name in "".join(human.stdout.split())  # the new backup's path is printed


def test_keep_orders_generations_by_their_manifests(
    on: Run, as_json: AsJson, tmp_path: Path
) -> None:
    source = tmp_path / "source"
    assert on("backup", str(source)).exit_code == 0
    root = tmp_path / "gens"
    root.mkdir()
    _generation(root, "backup-20991231T000000000000Z", "2020-01-01T00:00:00+00:00", source)
    _generation(root, "backup-20000101T000000000000Z", "2024-06-01T00:00:00+00:00", source)
    data = as_json(on("--json", "backup", str(root), "--keep", "2"))
    kept = sorted(p.name for p in root.iterdir())
    # The new one and the newer of the two by "created" (whatever the names say).
    assert kept == sorted(["backup-20000101T000000000000Z", Path(data["path"]).name])


# -- a backup killed part-way ----------------------------------------------------------------


@pytest.fixture
def killed_backup(tmp_path: Path) -> Iterator[Path]:
    """A --keep folder with one generation and the .part folder a SIGKILLed backup left."""
    root = tmp_path / "gens"
    with Client("sim://?speedup=50") as client:
        client.backup(root, keep=3)
    stale = root / ".backup-20240101T000000000000Z.ab_cd123.part"
    (stale / "ch1").mkdir(parents=True)
    (stale / "ch1" / "DEMO.JOB").write_text("MAIN\n")
    old = time.time() - backup.STALE_AFTER - 60
    for path in (stale / "ch1" / "DEMO.JOB", stale / "ch1", stale):
        os.utime(path, (old, old))
    yield root


def test_a_leftover_part_folder_does_not_block_keep(
    on: Run, as_json: AsJson, killed_backup: Path
) -> None:
    result = on("--json", "backup", str(killed_backup), "--keep", "3")
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in killed_backup.iterdir())
    assert len(names) == 2 and all(n.startswith("backup-") for n in names)  # stale one removed


def test_a_recent_part_folder_is_left_alone(on: Run, killed_backup: Path) -> None:
    running = killed_backup / ".backup-20990101T000000000000Z.zz999999.part"
    running.mkdir()  # as if another backup were writing it now
    assert on("backup", str(killed_backup), "--keep", "3").exit_code == 0
    assert running.is_dir()


def test_keep_still_refuses_a_folder_that_is_not_its_own(on: Run, killed_backup: Path) -> None:
    (killed_backup / ".notes.part").mkdir()  # not a name this module makes
    result = on("backup", str(killed_backup), "--keep", "3")
    assert result.exit_code == 2
    assert ".notes.part" in result.stderr
