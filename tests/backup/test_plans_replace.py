"""`backup DIR` replaces a previous backup only when that is safe: never another robot's
backup without --replace, never a file of anyone else's (notes, photos) kept in DIR."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from .conftest import RealControllerStandIn, Run


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file()
    }


def test_a_file_of_the_technicians_is_never_deleted(on: Run, tmp_path: Path) -> None:
    folder = tmp_path / "line3"
    assert on("backup", str(folder)).exit_code == 0
    (folder / "NOTES.txt").write_text("gripper offsets re-taught\n")
    (folder / "ch1" / "photo.jpg").write_bytes(b"\xff\xd8")
    before = _snapshot(folder)
    for extra in ((), ("--replace",)):
        result = on("backup", str(folder), *extra)
        assert result.exit_code == 2, result.output
        assert "'NOTES.txt' and 1 more" in result.stderr and "move it out" in result.stderr
        assert _snapshot(folder) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["line3"]  # no temporary folder left


def test_a_simulators_backup_does_not_replace_a_controllers(
    run: Run, served: Callable[..., str], tmp_path: Path
) -> None:
    folder = tmp_path / "line3"
    real = served(RealControllerStandIn())
    assert run("backup", str(folder), port=real).exit_code == 0
    before = _snapshot(folder)
    result = run("backup", str(folder), port="sim://")
    assert result.exit_code == 2, result.output
    assert "(a controller), not of sim:// (a simulator)" in result.stderr
    assert "--replace" in result.stderr
    assert _snapshot(folder) == before
    assert run("backup", str(folder), "--replace", port="sim://").exit_code == 0
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["simulator"] is True and manifest["target"] == "sim://"


def test_a_backup_of_another_target_is_replaced_only_with_replace(
    run: Run, served: Callable[..., str], tmp_path: Path
) -> None:
    folder = tmp_path / "line3"
    first, second = served(RealControllerStandIn()), served(RealControllerStandIn())
    assert run("backup", str(folder), port=first).exit_code == 0
    assert run("backup", str(folder), port=first).exit_code == 0  # the same target: as before
    before = _snapshot(folder)
    result = run("backup", str(folder), port=second)
    assert result.exit_code == 2 and f"not of {second}" in result.stderr
    assert _snapshot(folder) == before
    assert run("backup", str(folder), "--replace", port=second).exit_code == 0
    assert json.loads((folder / "manifest.json").read_text())["target"] == second


def test_an_older_manifest_is_known_as_a_simulators_by_its_identity(
    run: Run, served: Callable[..., str], tmp_path: Path
) -> None:
    folder = tmp_path / "bench"
    assert run("backup", str(folder), port="sim://").exit_code == 0
    manifest = json.loads((folder / "manifest.json").read_text())
    del manifest["target"], manifest["simulator"]  # written before they were recorded
    (folder / "manifest.json").write_text(json.dumps(manifest))
    result = run("backup", str(folder), port=served(RealControllerStandIn()))
    assert result.exit_code == 2 and "backup of a simulator" in result.stderr
