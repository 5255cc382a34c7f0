"""A file put into a backup folder while the backup runs is not deleted by its swap."""

from __future__ import annotations

from pathlib import Path

import pytest

from robostar.client import Client
from robostar.errors import UsageError


def test_a_file_put_there_during_the_backup_is_kept(tmp_path: Path) -> None:
    folder = tmp_path / "bk"
    with Client("sim://?speedup=50") as client:
        client.backup(folder)
        notes = folder / "NOTES.txt"

        def meanwhile(done: int, total: int | None) -> None:
            if done == 1:
                notes.write_text("written while the backup ran\n")

        with pytest.raises(UsageError, match=r"NOTES\.txt"):
            client.backup(folder, progress=meanwhile)
    assert notes.read_text() == "written while the backup ran\n"
    assert (folder / "manifest.json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bk"]
