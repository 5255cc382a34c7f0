"""Item 5, a whole cell from one process: one asyncio loop polls N controllers at 10 Hz each.

The simulators run in one other process (two for more than 32 controllers, half each), one
virtual controller per TCP port. Each controller gets a task that, ten times a second on a
fixed schedule (the tasks spread evenly over the period), reads status (AA) and the channel-1
position (AC). A poll that ends after its next tick was due skips the ticks it missed, as a
monitor would, so the achieved rate is the share of ticks served. Latency is from the tick to
the end of the poll's second answer; CPU is this process's user + system time.
"""

from __future__ import annotations

import asyncio
import math
import sys
import time
from dataclasses import dataclass, field
from typing import Any

from bench.measure import Row, percentile
from bench.procs import ServerProcess, sim_command
from robostar import AsyncClient

__all__ = ["run"]

RATE_HZ = 10.0
TARGET = 0.99
TARGET_NS = (128, 256)
"""The targets: 128 controllers at 99 % of the asked rate or better (issue "Benchmarks"), and
256 with the simulators in processes of their own (issue #18). On a 2-core machine both have
the simulators on the same two cores as the client."""
PER_PROCESS = 64


@dataclass
class _Stats:
    done: int = 0
    missed: int = 0
    latencies: list[float] = field(default_factory=list)


async def _poller(client: AsyncClient, first: float, end: float, stats: _Stats) -> None:
    period = 1.0 / RATE_HZ
    tick = first
    while tick < end:
        await asyncio.sleep(max(tick - time.monotonic(), 0.0))
        await client.status()
        await client.position(1)
        done = time.monotonic()
        stats.done += 1
        stats.latencies.append(done - tick)
        tick += period
        if done > tick:
            skipped = math.ceil((done - tick) / period)
            stats.missed += skipped
            tick += skipped * period


async def _cell(urls: list[str], seconds: float) -> tuple[_Stats, float, float]:
    clients = [AsyncClient(url, timeout=2.0) for url in urls]
    try:
        for client in clients:
            await client.connect()
            await client.status()
        stats = _Stats()
        period = 1.0 / RATE_HZ
        start = time.monotonic() + 0.2
        end = start + seconds
        cpu = time.process_time()
        tasks = [
            asyncio.create_task(_poller(c, start + i * period / len(clients), end, stats))
            for i, c in enumerate(clients)
        ]
        await asyncio.gather(*tasks)
        wall = time.monotonic() - start
        cpu = time.process_time() - cpu
        return stats, wall, cpu
    finally:
        for client in clients:
            await client.close()


def _one(n: int, seconds: float) -> dict[str, Any]:
    sizes = [n] if n <= PER_PROCESS // 2 else [n // 2, n - n // 2]
    servers = [ServerProcess(sim_command(count=k), ready_lines=k) for k in sizes]
    try:
        for server in servers:
            server.start()
        urls = [url for server in servers for url in server.lines]
        sim_cpu = sum(s.cpu_seconds() for s in servers)
        stats, wall, cpu = asyncio.run(_cell(urls, seconds))
        sim_cpu = sum(s.cpu_seconds() for s in servers) - sim_cpu
    finally:
        for server in servers:
            server.__exit__(None, None, None)
    asked = stats.done + stats.missed
    return {
        "controllers": n,
        "sim_processes": len(sizes),
        "seconds": wall,
        "asked_polls_per_s": n * RATE_HZ,
        "polls_per_s": stats.done / wall,
        "achieved": stats.done / asked if asked else math.nan,
        "missed": stats.missed,
        "latency_p50_ms": percentile(stats.latencies, 50) * 1000,
        "latency_p99_ms": percentile(stats.latencies, 99) * 1000,
        "latency_max_ms": max(stats.latencies, default=math.nan) * 1000,
        "client_cpu": cpu / wall,
        "sim_cpu": sim_cpu / wall,
        "client_cpu_us_per_exchange": cpu / max(2 * stats.done, 1) * 1e6,
    }


def run(
    *, sizes: tuple[int, ...] = (1, 8, 32, 128, 256), seconds: float = 20.0
) -> tuple[dict[str, Any], list[Row]]:
    results: dict[str, Any] = {"rate_hz": RATE_HZ, "seconds": seconds, "by_n": []}
    rows = []
    for n in sizes:
        entry = _one(n, seconds)
        results["by_n"].append(entry)
        rows.append(
            Row(
                "5 cell",
                f"N={n}: achieved rate (CPU {entry['client_cpu']:.0%} client,"
                f" {entry['sim_cpu']:.0%} sims)",
                f"{entry['polls_per_s']:,.1f}/s of {entry['asked_polls_per_s']:,.0f}"
                f" ({entry['achieved']:.1%}), p99 {entry['latency_p99_ms']:.1f} ms",
                f"≥ {TARGET:.0%}" if n in TARGET_NS else "",
                entry["achieved"] >= TARGET if n in TARGET_NS else None,
            )
        )
    return results, rows


if __name__ == "__main__":
    print(run(sizes=tuple(int(a) for a in sys.argv[1:]) or (1, 8), seconds=3.0))
