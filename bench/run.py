"""Run every benchmark in one process run: print the table, write JSON, render the plots.

``python bench/run.py`` runs the issue's sizes (about 10 minutes); ``--quick`` shortens the jog
to 10 s, the cell to N = 1, 8, 32 for 5 s each, and the other loops, for an everyday check.
``--only`` picks items by name. Results go to ``bench/results/`` (``latest.json``, a dated
copy, the table as Markdown in ``latest.md``, and the two PNGs); ``--docs`` also copies the
PNGs to ``docs/img/`` for ``docs/performance.md``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

if __package__ in (None, ""):
    # Run as a script (``python bench/run.py``): make ``bench`` and ``robostar`` importable.
    _root = Path(__file__).resolve().parent.parent
    sys.path[:0] = [str(_root), str(_root / "src")]

import psutil

from bench import backup_loop, cell, host_cost, jog, loopback, memory, plots, wire
from bench.measure import Row, format_table

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
DOC_IMAGES = ROOT / "docs" / "img"

Item = Callable[[], tuple[dict[str, Any], list[Row]]]


def _items(quick: bool) -> dict[str, Item]:
    if quick:
        return {
            "host": lambda: host_cost.run(n=1000, rounds=7),
            "loopback": lambda: loopback.run(seconds=0.5, rounds=3),
            "wire": lambda: wire.run(lines=500, polls=300, packets=30, rounds=1),
            "jog": lambda: jog.run(seconds=10.0),
            "cell": lambda: cell.run(sizes=(1, 8, 32), seconds=5.0),
            "memory": lambda: memory.run(exchanges=10_000),
            "backup_loop": lambda: backup_loop.run(jobs=2, rounds=1),
        }
    return {
        "host": lambda: host_cost.run(),
        "loopback": lambda: loopback.run(),
        "wire": lambda: wire.run(),
        "jog": lambda: jog.run(seconds=60.0),
        "cell": lambda: cell.run(sizes=(1, 8, 32, 128, 256), seconds=20.0),
        "memory": lambda: memory.run(exchanges=1_000_000),  # issue #18: RSS flat over 1e6
        "backup_loop": lambda: backup_loop.run(),
    }


def _machine() -> dict[str, Any]:
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    return {
        "python": platform.python_version(),
        "implementation": platform.python_implementation(),
        "system": platform.platform(),
        "cpus": os.cpu_count(),
        "load_average": load,
        "memory_mb": psutil.virtual_memory().total // 2**20,
    }


def _render(report: dict[str, Any], out: Path, docs: bool) -> None:
    """Draw the plots of the items the report holds; with ``docs``, copy them to docs/img/."""
    pngs = []
    if "wire" in report["items"]:
        plots.plot_wire(report["items"]["wire"], out / "wire.png")
        pngs.append(out / "wire.png")
    if "cell" in report["items"]:
        plots.plot_cell(report["items"]["cell"], out / "cell.png")
        pngs.append(out / "cell.png")
    if docs:
        DOC_IMAGES.mkdir(parents=True, exist_ok=True)
        for png in pngs:
            shutil.copy(png, DOC_IMAGES / f"performance-{png.name}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="bench/run.py", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs for an everyday check")
    parser.add_argument(
        "--only",
        default="",
        metavar="ITEMS",
        help="comma-separated: host, loopback, wire, jog, cell, memory (default: all)",
    )
    parser.add_argument("--out", type=Path, default=RESULTS, help="where results go")
    parser.add_argument("--docs", action="store_true", help="copy the plots to docs/img/")
    parser.add_argument(
        "--replot", action="store_true", help="only redraw the plots from --out's latest.json"
    )
    args = parser.parse_args(argv)
    if args.replot:
        _render(json.loads((args.out / "latest.json").read_text()), args.out, args.docs)
        return 0

    items = _items(args.quick)
    chosen = [name.strip() for name in args.only.split(",") if name.strip()] or list(items)
    unknown = [name for name in chosen if name not in items]
    if unknown:
        parser.error(f"--only: unknown item(s) {', '.join(unknown)}; pick from {', '.join(items)}")

    started = datetime.datetime.now(datetime.UTC)
    report: dict[str, Any] = {
        "started": started.isoformat(timespec="seconds"),
        "mode": "quick" if args.quick else "full",
        "machine": _machine(),
        "items": {},
        "seconds": {},
    }
    rows: list[Row] = []
    for name in chosen:
        print(f"-- {name} ...", file=sys.stderr, flush=True)
        t = time.perf_counter()
        results, item_rows = items[name]()
        report["seconds"][name] = time.perf_counter() - t
        report["items"][name] = results
        rows += item_rows
    report["table"] = [row.as_dict() for row in rows]
    report["machine"]["load_average_end"] = os.getloadavg() if hasattr(os, "getloadavg") else None

    print(format_table(rows))
    args.out.mkdir(parents=True, exist_ok=True)
    text = json.dumps(report, indent=1, default=str)
    (args.out / "latest.json").write_text(text + "\n")
    stamp = started.strftime("%Y%m%dT%H%M%SZ")
    (args.out / f"{stamp}-{report['mode']}.json").write_text(text + "\n")
    (args.out / "latest.md").write_text(format_table(rows, markdown=True) + "\n")
    _render(report, args.out, args.docs)
    print(f"results: {args.out / 'latest.json'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
