"""An AsyncClient's backup and restore on a slow disk, beside a task ticking every 10 ms:
``python -m bench.backup_loop``. Figures, printed, never asserted.

The slow disk: every operation of the backup store (robostar.backup.store: the folder checks,
the temporary folder, each file written or read, the manifest, the swap into place, pruning)
takes 100 ms more. The gap between two ticks of the 10 ms task says how long the event loop
was held. "inline" runs the store's operations on the loop itself, as the backup did before
it asked its client to run them (robostar.client.plan.Blocking); "thread" is the asyncio
client's way now, a worker thread; "reference" is the new way with no slowed disk, for the
gaps a loaded machine and the line make without any file work. Goal: no gap above 50 ms.
"""

from __future__ import annotations

import argparse
import asyncio
import functools
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from bench.measure import Row, format_table, percentile
from robostar.backup import store
from robostar.client import AsyncClient
from robostar.client.plan import Blocking, Effect

__all__ = ["main", "run"]

TICK = 0.010
SLOW = 0.100
TARGET_MAX_GAP = 0.050
SIM = "sim://?speedup=50"
OPERATIONS = (
    "previous_backup",
    "start",
    "write_file",
    "write_manifest",
    "put_in_place",
    "tidy",
    "discard",
    "read_manifest",
    "read_file",
)


@contextmanager
def slow_disk(seconds: float) -> Iterator[list[str]]:
    """Every store operation ``seconds`` slower; yields the names of those that ran."""
    ran: list[str] = []
    originals = {name: getattr(store, name) for name in OPERATIONS}

    def slowed(name: str, original: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(original)
        def operation(*args: Any, **kwargs: Any) -> Any:
            ran.append(name)
            time.sleep(seconds)
            return original(*args, **kwargs)

        return operation

    for name, original in originals.items():
        setattr(store, name, slowed(name, original))
    try:
        yield ran
    finally:
        for name, original in originals.items():
            setattr(store, name, original)


@contextmanager
def file_work_inline() -> Iterator[None]:
    """The asyncio client runs the store's operations on the event loop (the old way)."""
    threaded = AsyncClient._perform

    async def perform(client: AsyncClient, effect: Effect) -> object:
        if isinstance(effect, Blocking):
            return effect.function()
        return await threaded(client, effect)

    setattr(AsyncClient, "_perform", perform)  # noqa: B010 (a method, for this run only)
    try:
        yield
    finally:
        setattr(AsyncClient, "_perform", threaded)  # noqa: B010


async def _ticked(work: Callable[[], Any]) -> tuple[list[float], float]:
    """Run ``work()`` (a coroutine function) beside a task ticking every TICK seconds: the gaps
    between ticks (s), and how long the work took."""
    gaps: list[float] = []
    running = True

    async def ticker() -> None:
        last = time.perf_counter()
        while running:
            await asyncio.sleep(TICK)
            now = time.perf_counter()
            gaps.append(now - last)
            last = now

    ticking = asyncio.create_task(ticker())
    await asyncio.sleep(0)
    started = time.perf_counter()
    await work()
    took = time.perf_counter() - started
    running = False
    await ticking
    return gaps, took


async def _measure(
    folder: Path, jobs: int, inline: bool, rounds: int, slow: float
) -> dict[str, dict[str, Any]]:
    gaps: dict[str, list[float]] = {"backup": [], "restore": []}
    took: dict[str, list[float]] = {"backup": [], "restore": []}
    operations: dict[str, int] = {}
    async with AsyncClient(SIM) as client:
        for channel in (1, 2):
            for n in range(jobs):
                lines = ["MAIN", *(f"MOVJ P{i} V=50" for i in range(1, 21)), "EOP"]
                await client.upload_job(channel, f"J{n:03d}.JOB", lines, number=100 + n)
        for _ in range(rounds):
            for what in ("backup", "restore"):

                async def work(what: str = what) -> None:
                    if what == "backup":
                        await client.backup(folder)
                    else:
                        await client.restore(folder)

                with slow_disk(slow) as ran, file_work_inline() if inline else _nothing():
                    these, seconds = await _ticked(work)
                gaps[what] += these
                took[what].append(seconds)
                operations[what] = len(ran)
    return {
        what: {
            "store_operations": operations[what],
            "gap_p50_ms": percentile(gaps[what], 50) * 1000,
            "gap_p99_ms": percentile(gaps[what], 99) * 1000,
            "gap_max_ms": max(gaps[what]) * 1000,
            "seconds": percentile(took[what], 50),
        }
        for what in gaps
    }


@contextmanager
def _nothing() -> Iterator[None]:
    yield


def run(*, jobs: int = 8, rounds: int = 3) -> tuple[dict[str, Any], list[Row]]:
    """Backup and restore of ``jobs`` JOB files per channel (two channels), old and new, each
    ``rounds`` times (the gaps of all rounds together; the median time of one)."""
    results: dict[str, Any] = {
        "tick_ms": TICK * 1000,
        "slow_ms": SLOW * 1000,
        "jobs": jobs,
        "rounds": rounds,
    }
    rows = []
    # "reference": the new way on a disk that is not slowed, for the gaps the machine and the
    # line make without any file work (a loaded machine's scheduler shows here too).
    modes = {"inline": (True, SLOW), "thread": (False, SLOW), "reference": (False, 0.0)}
    for mode, (inline, slow) in modes.items():
        with tempfile.TemporaryDirectory() as scratch:
            folder = Path(scratch) / "bk"
            figures = asyncio.run(_measure(folder, jobs, inline, rounds, slow))
        results[mode] = figures
        for what, f in figures.items():
            met = f["gap_max_ms"] <= TARGET_MAX_GAP * 1000 if mode == "thread" else None
            rows.append(
                Row(
                    "backup loop",
                    f"{what}, file work {mode}, {slow * 1000:.0f} ms/op "
                    f"({f['store_operations']} ops, {f['seconds']:.1f} s)",
                    f"p50 {f['gap_p50_ms']:.1f}, p99 {f['gap_p99_ms']:.1f}, "
                    f"max {f['gap_max_ms']:.1f} ms",
                    "max gap <= 50 ms" if mode == "thread" else "",
                    met,
                )
            )
    return results, rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0] if __doc__ else None)
    parser.add_argument("--jobs", type=int, default=8, help="JOB files per channel (8)")
    parser.add_argument("--rounds", type=int, default=3, help="runs of each (3)")
    args = parser.parse_args(argv)
    print(
        f"AsyncClient backup and restore, a task ticking every {TICK * 1000:.0f} ms, every "
        f"store operation {SLOW * 1000:.0f} ms slower:"
    )
    _, rows = run(jobs=args.jobs, rounds=args.rounds)
    print(format_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
