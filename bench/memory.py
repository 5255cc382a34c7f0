"""Item 6, memory: this process's resident memory over many exchanges with the simulator
(a million in the full run, issue #18; ten thousand with --quick).

The blocking client alternates AA and AC against ``python -m robostar.sim``. Resident memory
(RSS) is read after a full garbage collection: at the start (client connected, nothing
exchanged), after a 1 000-exchange warm-up, then every tenth of the run. Growth is counted
from the start, so warm-up allocations (caches, interned names) count against us too.
"""

from __future__ import annotations

import gc
import time
from typing import Any

import psutil

from bench.measure import Row
from bench.procs import ServerProcess, sim_command
from robostar import Client

__all__ = ["run"]

TARGET_MB = 5.0
WARMUP = 1000


def _rss_mb() -> float:
    gc.collect()
    return int(psutil.Process().memory_info().rss) / 2**20


def run(*, exchanges: int = 100_000, warmup: int = WARMUP) -> tuple[dict[str, Any], list[Row]]:
    with ServerProcess(sim_command()) as sim, Client(sim.lines[0]) as client:
        start = _rss_mb()

        def burst(n: int) -> None:
            for _ in range(n // 2):
                client.status()
                client.position(1)
            if n % 2:
                client.status()

        burst(warmup)
        warm = _rss_mb()
        samples = [(0, start), (warmup, warm)]
        step = max(exchanges // 10, 2)
        done = 0
        wall = time.perf_counter()
        while done < exchanges:
            n = min(step, exchanges - done)
            burst(n)
            done += n
            samples.append((warmup + done, _rss_mb()))
        wall = time.perf_counter() - wall
    end = samples[-1][1]
    growth = end - start
    results = {
        "exchanges": exchanges,
        "rss_start_mb": start,
        "rss_after_warmup_mb": warm,
        "rss_end_mb": end,
        "growth_mb": growth,
        "growth_after_warmup_mb": end - warm,
        "samples": samples,
        "seconds": wall,
    }
    row = Row(
        "6 memory",
        f"RSS growth over {exchanges:,} exchanges",
        f"{growth:+.2f} MB ({start:.1f} → {end:.1f} MB; {end - warm:+.2f} after warm-up)",
        f"< {TARGET_MB:g} MB",
        growth < TARGET_MB,
    )
    return results, [row]
