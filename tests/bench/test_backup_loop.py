"""Smoke test of bench/backup_loop.py (python -m bench.backup_loop): it runs end to end, old
and new, and reports the gap figures. No figure is judged here."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench import backup_loop  # noqa: E402
from robostar.client import AsyncClient  # noqa: E402


def test_the_backup_loop_bench_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(backup_loop, "SLOW", 0.001)
    perform = AsyncClient._perform
    results, rows = backup_loop.run(jobs=1, rounds=1)
    assert AsyncClient._perform is perform  # the old way is undone after its run
    for mode in ("inline", "thread", "reference"):
        for what in ("backup", "restore"):
            figures = results[mode][what]
            assert figures["store_operations"] > 0
            assert figures["gap_max_ms"] >= figures["gap_p50_ms"] > 0
    assert len(rows) == 6
