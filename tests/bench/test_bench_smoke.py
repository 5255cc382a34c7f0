"""Smoke test of the benchmarks: each runs with tiny sizes, so that none of them rots.

No figure is judged here (benchmarks print figures; they are not timed tests): only that each
benchmark runs end to end and reports the fields the runner, the plots and docs/performance.md
read. Needs the ``bench`` extra (pymodbus, psutil, matplotlib); skipped without it.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

pytest.importorskip("pymodbus")
pytest.importorskip("psutil")
pytest.importorskip("matplotlib")

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.measure import Row, format_table  # noqa: E402

from bench import cell, host_cost, jog, loopback, memory, plots, run, wire  # noqa: E402

pytestmark = pytest.mark.timeout(120)


def _finite(value: object) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)


def _check_rows(rows: list[Row], item: str) -> None:
    assert rows
    assert all(row.item.startswith(item) for row in rows)
    assert format_table(rows).count("\n") == len(rows) + 1


def test_host_cost() -> None:
    results, rows = host_cost.run(n=20, rounds=1, fa_lines=8)
    _check_rows(rows, "1")
    cases = results["cases"]
    assert set(cases) == {"AA", "AC (4 axes)", "GR point (6 axes)", "FA line packet"}
    # AA is request 6 + answer 7 + ACK 1 bytes, as the issue counts it.
    assert cases["AA"]["wire_bytes"] == 14
    assert all(_finite(case["cpu_us"]) and case["cpu_us"] > 0 for case in cases.values())
    assert results["client_in_memory_aa_us"] > 0


def test_loopback() -> None:
    results, rows = loopback.run(seconds=0.05, rounds=1)
    _check_rows(rows, "2")
    contenders = results["contenders"]
    assert {"raw floor", "pymodbus sync", "pymodbus async", "robostar async AC"} <= set(contenders)
    for entry in contenders.values():
        assert entry["rate"] > 0 and _finite(entry["client_cpu_us"])
    assert contenders["raw floor"]["rate_vs_floor"] == 1.0
    # asyncio clients are measured against asyncio's floor, blocking ones against the raw one
    assert contenders["asyncio floor"]["rate_vs_floor"] == 1.0
    assert contenders["robostar async AA"]["floor"] == "asyncio floor"
    assert contenders["robostar sync AA"]["floor"] == "raw floor"
    assert results["vs_floor_async"]["floor"] == "asyncio floor"


def test_wire_and_plot(tmp_path: Path) -> None:
    results, rows = wire.run(lines=12, polls=5, packets=2, rounds=1)
    _check_rows(rows, "3")
    transfers = ("FB upload", "FA download", "AA polls", "250-byte packets")
    expected = {wire.case_name(t, line) for t in transfers for line in ("tcp", "pty")}
    assert set(results["cases"]) == expected == set(results["raw_host"])
    for case in results["cases"].values():
        assert case["bytes"] > 0 and case["seconds"] >= case["floor"] > 0
        assert case["host"] >= 0 and _finite(case["over"])
    # one 250-byte answer packet per read, besides the request, END and the ACKs
    assert results["cases"]["250-byte packets"]["bytes"] >= 2 * 250
    assert set(results["hop_us"]) == {"tcp", "pty"}
    assert all(_finite(hop) and hop > 0 for hop in results["hop_us"].values())
    plots.plot_wire(results, tmp_path / "wire.png")
    assert (tmp_path / "wire.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_jog() -> None:
    results, rows = jog.run(seconds=0.7)
    _check_rows(rows, "4")
    assert results["jog_error"] is None
    assert results["keepalives"] >= 3  # BE and at least two BFs
    assert 0 < results["gap_max"] < 0.5
    assert all(rate > 0 for rate in results["polls_per_s"].values())


def test_cell_and_plot(tmp_path: Path) -> None:
    results, rows = cell.run(sizes=(1, 2), seconds=0.5)
    _check_rows(rows, "5")
    assert [e["controllers"] for e in results["by_n"]] == [1, 2]
    for entry in results["by_n"]:
        assert entry["polls_per_s"] > 0 and _finite(entry["latency_p99_ms"])
    plots.plot_cell(results, tmp_path / "cell.png")
    assert (tmp_path / "cell.png").stat().st_size > 1000


def test_memory() -> None:
    results, rows = memory.run(exchanges=200, warmup=20)
    _check_rows(rows, "6")
    assert len(results["samples"]) >= 3
    assert results["rss_start_mb"] > 0


def test_runner_writes_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert run.main(["--quick", "--only", "host", "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "latest.json").read_text())
    assert report["mode"] == "quick"
    assert list(report["items"]) == ["host"]
    assert report["table"][0]["item"] == "1 host cost"
    assert "1 host cost" in capsys.readouterr().out
