"""The program version store: a version per change of a file's text (not per read), texts kept
once by hash, the retention bound (and the texts no version holds deleted), versions looked up by
number or hash, line diffs, and the same behaviour on disk as in memory."""

from __future__ import annotations

from pathlib import Path

import pytest

from robostar.errors import UsageError
from robostar.serve.lease import Who
from robostar.serve.programs import ProgramStore, diff_lines, program_text
from robostar.types import JobFile, Point, PointFile

ERIN = Who("erin", "web")
JOB_A = "MAIN\nMOVJ P0001\nEOP\n"
JOB_B = "MAIN\nMOVJ P0002\nEOP\n"


@pytest.fixture(params=["memory", "disk"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> ProgramStore:
    return ProgramStore(None if request.param == "memory" else tmp_path / "programs", retention=3)


def test_a_version_per_change_not_per_read(store: ProgramStore) -> None:
    first = store.record("cell1", 1, "DEMO.JOB", JOB_A, ERIN, "upload")
    assert first is not None and first.who == "erin" and first.how == "upload"
    assert first.size == len(JOB_A)
    assert store.record("cell1", 1, "demo.job", JOB_A, Who("olga", "web"), "download") is None
    second = store.record("cell1", 1, "DEMO.JOB", JOB_B, ERIN, "upload")
    assert [v.hash for v in store.versions("cell1", 1, "DEMO.JOB")] == [second.hash, first.hash]
    assert store.text(first.hash) == JOB_A
    assert store.files("cell1") == [(1, "DEMO.JOB")]
    assert store.versions("cell1", 2, "DEMO.JOB") == []


def test_retention_drops_the_oldest_and_their_texts(store: ProgramStore) -> None:
    texts = [f"MAIN\nDELAY {n}\nEOP\n" for n in range(5)]
    made = [store.record("cell1", 1, "A.JOB", t, ERIN, "upload") for t in texts]
    store.record("cell1", 1, "B.JOB", texts[1], ERIN, "upload")  # B keeps text 1 alive
    kept = store.versions("cell1", 1, "A.JOB")
    assert [v.hash for v in kept] == [m.hash for m in reversed(made[2:]) if m]
    with pytest.raises(UsageError):
        store.text(made[0].hash)  # type: ignore[union-attr]
    assert store.text(made[1].hash) == texts[1]  # type: ignore[union-attr]


def test_versions_are_found_by_number_or_hash(store: ProgramStore) -> None:
    a = store.record("cell1", 1, "DEMO.JOB", JOB_A, ERIN, "upload")
    b = store.record("cell1", 1, "DEMO.JOB", JOB_B, ERIN, "upload")
    assert a is not None and b is not None
    assert store.find("cell1", 1, "DEMO.JOB", "1") == a
    assert store.find("cell1", 1, "DEMO.JOB", "-1") == b
    assert store.find("cell1", 1, "DEMO.JOB", b.hash[:8]) == b
    for bad in ("3", "0", "zz"):
        with pytest.raises(UsageError):
            store.find("cell1", 1, "DEMO.JOB", bad)


def test_a_diff_shows_the_changed_line() -> None:
    diff = diff_lines(JOB_A, JOB_B, "v1", "v2")
    assert "-MOVJ P0001" in diff and "+MOVJ P0002" in diff
    assert diff_lines(JOB_A, JOB_A, "v1", "v2") == []


def test_the_kept_text_is_the_files_lines() -> None:
    assert program_text(JobFile(("MAIN", "EOP"))) == "MAIN\nEOP\n"
    points = program_text(PointFile({1: Point((1.0, 2.0, 3.0, 4.0))}))
    assert points.startswith("P0001") and points.endswith("\n")


def test_names_cannot_leave_the_store(tmp_path: Path) -> None:
    store = ProgramStore(tmp_path)
    with pytest.raises(UsageError):
        store.record("../x", 1, "A.JOB", JOB_A, ERIN, "upload")
    with pytest.raises(UsageError):
        ProgramStore(tmp_path, retention=0)


def test_the_disk_store_is_read_back_by_a_new_store(tmp_path: Path) -> None:
    ProgramStore(tmp_path).record("cell1", 2, "DEMO.PNT", "P0001\n", ERIN, "backup")
    again = ProgramStore(tmp_path)
    (version,) = again.versions("cell1", 2, "DEMO.PNT")
    assert again.text(version.hash) == "P0001\n" and version.how == "backup"
