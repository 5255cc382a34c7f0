"""Tests of the state directory: round trips; a crash mid-save never loses the old state."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest

from robostar.errors import UsageError
from robostar.sim.store import STATE_FILE, StateStore

OLD = {"speed": [500, 1000, 1000], "globals": {"int": {"3": 7}}, "files": ["A.JOB"]}
NEW = {"speed": [100, 1000, 1000], "globals": {"int": {}}, "files": []}


def leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name != STATE_FILE)


def test_nothing_saved_loads_as_none(tmp_path: Path) -> None:
    assert StateStore(tmp_path / "never").load() is None
    assert not (tmp_path / "never").exists()


def test_a_snapshot_round_trips_and_a_save_replaces_it(tmp_path: Path) -> None:
    store = StateStore(tmp_path / "state")
    store.save(OLD)
    assert store.load() == OLD
    store.save(NEW)
    assert StateStore(tmp_path / "state").load() == NEW
    assert leftovers(tmp_path / "state") == []


def test_the_file_is_plain_json(tmp_path: Path) -> None:
    StateStore(tmp_path).save(OLD)
    assert json.loads((tmp_path / STATE_FILE).read_text(encoding="utf-8")) == OLD


def test_a_crash_before_the_rename_keeps_the_old_state(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store = StateStore(tmp_path)
    store.save(OLD)

    def crash(src: str, dst: str) -> None:
        raise OSError("power cut")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(OSError, match="power cut"):
        store.save(NEW)
    monkeypatch.undo()
    assert store.load() == OLD
    assert leftovers(tmp_path) == []


def test_a_crash_while_writing_keeps_the_old_state(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store = StateStore(tmp_path)
    store.save(OLD)

    def crash(fd: int) -> None:
        raise OSError("disk gone")

    monkeypatch.setattr(os, "fsync", crash)
    with pytest.raises(OSError, match="disk gone"):
        store.save(NEW)
    monkeypatch.undo()
    assert store.load() == OLD
    assert leftovers(tmp_path) == []


def test_a_process_killed_mid_save_leaves_the_old_state_and_its_temp_is_cleaned(
    tmp_path: Path,
) -> None:
    store = StateStore(tmp_path)
    store.save(OLD)
    # What a kill -9 between writing the temporary file and renaming it leaves behind.
    (tmp_path / ".state-abc123.tmp").write_text('{"speed": [1', encoding="utf-8")
    assert store.load() == OLD
    assert leftovers(tmp_path) == []


def test_a_snapshot_json_cannot_hold_is_refused_before_any_file_is_touched(
    tmp_path: Path,
) -> None:
    store = StateStore(tmp_path)
    store.save(OLD)
    with pytest.raises(TypeError):
        store.save({"bad": object()})
    with pytest.raises(ValueError):
        store.save({"bad": float("nan")})
    assert store.load() == OLD
    assert leftovers(tmp_path) == []


def test_the_file_and_then_the_directory_are_synced(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    synced: list[str] = []
    real_fsync = os.fsync

    def spy(fd: int) -> None:
        synced.append("dir" if stat.S_ISDIR(os.fstat(fd).st_mode) else "file")
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", spy)
    StateStore(tmp_path).save(OLD)
    assert synced == ["file", "dir"]


def test_a_damaged_state_file_is_reported_with_its_path(tmp_path: Path) -> None:
    (tmp_path / STATE_FILE).write_text("{not json", encoding="utf-8")
    with pytest.raises(UsageError, match=r"state directory.*not valid JSON"):
        StateStore(tmp_path).load()
    (tmp_path / STATE_FILE).write_text("[1, 2]", encoding="utf-8")
    with pytest.raises(UsageError, match="JSON object"):
        StateStore(tmp_path).load()


def test_a_file_in_place_of_the_directory_is_refused(tmp_path: Path) -> None:
    (tmp_path / "taken").write_text("", encoding="utf-8")
    with pytest.raises(UsageError, match="state directory"):
        StateStore(tmp_path / "taken")


def test_a_snapshot_must_be_a_dict(tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="snapshot"):
        StateStore(tmp_path).save([1, 2])  # type: ignore[arg-type]
