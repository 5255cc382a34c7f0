"""--keep generations: the backup just made is never deleted, the others are pruned by their
manifests' created time (not their folder names); a temporary folder a killed backup left
is removed once stale, a recent one (a backup running now) is left alone, and a folder that
is not --keep's own is still refused."""

from __future__ import annotations

import json
import os
import shutil
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from robostar import backup
from robostar.client import Client

from .conftest import AsJson, Run


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
