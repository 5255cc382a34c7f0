"""The manifest records the target a backup was read from and whether it is a simulator; a
manifest written before they were recorded is still read (and restored from)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from robostar.backup import Manifest

from .conftest import AsJson, Run


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
