"""Item 2, loopback TCP: exchanges per second and client CPU per exchange, side by side.

Contenders, each a client in this process against a server in another process:

- ``raw floor``: the three messages over blocking sockets (:mod:`bench.floor`);
- ``asyncio floor``: the same on asyncio, an ``asyncio.Protocol`` that ACKs a whole answer
  where it lands (:func:`bench.floor.async_client_loop`): the async contenders' floor;
- ``pymodbus sync`` / ``pymodbus async``: read 10 holding registers from pymodbus's server;
- ``robostar sync|async AA|AC``: :class:`~robostar.Client` / :class:`~robostar.AsyncClient`
  against the simulator (``python -m robostar.sim``), AA (status) and AC (4-axis position);
- the pymodbus clients and the four robostar ones again, each against a server as minimal
  as the floor's that sends fixed answers (``python -m bench.floor modbus|canned``): each
  client library's own speed, without its server's cost in the round trip. The issue's
  targets are judged on the simulator rows.

Every round runs each contender for a fixed time, in an order that rotates from round to
round; the figures are medians over rounds, and each ratio is the median of the per-round
ratios against the matching floor of the same round (the raw floor for blocking clients, the
asyncio floor for asyncio ones), so a noisy neighbour weighs on both alike. Client
CPU is this process's user + system time; server CPU is read from the server process.

On Linux with two CPUs or more, the clients (this process) run on one CPU and every server on
another: where the scheduler puts two processes that wake each other decides the rate more
than either's code (one round may run both on one core, the next on two, and the rate halves
or doubles), so each contender gets the same placement. ``pin=False`` leaves it to the
scheduler.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from bench import floor, modbus_ref
from bench.measure import Row, median
from bench.procs import ServerProcess, sim_command
from robostar import AsyncClient, Client

__all__ = ["run"]

RATE_TARGET = 0.85
CPU_TARGET = 1.2
_LIMIT = 10_000_000


@dataclass
class _Sample:
    count: int
    wall: float
    cpu: float
    server_cpu: float

    @property
    def rate(self) -> float:
        return self.count / self.wall

    @property
    def cpu_us(self) -> float:
        return self.cpu / self.count * 1e6

    @property
    def server_us(self) -> float:
        return self.server_cpu / self.count * 1e6


Loop = Callable[[float], int]
"""Runs exchanges for about that many seconds; returns how many."""


def _measure(loop: Loop, seconds: float, server: ServerProcess) -> _Sample:
    server_before = server.cpu_seconds()
    cpu = time.process_time()
    wall = time.perf_counter()
    count = loop(seconds)
    wall = time.perf_counter() - wall
    cpu = time.process_time() - cpu
    return _Sample(count, wall, cpu, server.cpu_seconds() - server_before)


def _sync_robostar(client: Client, what: str) -> Loop:
    call = client.status if what == "AA" else lambda: client.position(1)

    def loop(seconds: float) -> int:
        end = time.perf_counter() + seconds
        done = 0
        while done < _LIMIT:
            call()
            done += 1
            if not done & 63 and time.perf_counter() >= end:
                break
        return done

    return loop


async def _async_robostar_loop(client: AsyncClient, what: str, seconds: float) -> int:
    end = time.perf_counter() + seconds
    done = 0
    while done < _LIMIT:
        if what == "AA":
            await client.status()
        else:
            await client.position(1)
        done += 1
        if not done & 63 and time.perf_counter() >= end:
            break
    return done


@contextlib.contextmanager
def _placed(pin: bool, servers: list[ServerProcess]) -> Iterator[str]:
    """Clients on the first CPU this process may use, servers on the second (see above)."""
    allowed = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    if not pin or len(allowed) < 2:
        yield "left to the scheduler"
        return
    client_cpu, server_cpu = allowed[0], allowed[1]
    for server in servers:
        # every thread: a process's affinity is its threads', and the servers' have started
        for task in os.listdir(f"/proc/{server.pid}/task"):
            os.sched_setaffinity(int(task), {server_cpu})
    os.sched_setaffinity(0, {client_cpu})
    try:
        yield f"clients on CPU {client_cpu}, servers on CPU {server_cpu}"
    finally:
        os.sched_setaffinity(0, set(allowed))


def run(
    *, seconds: float = 1.5, rounds: int = 7, pin: bool = True
) -> tuple[dict[str, Any], list[Row]]:
    samples: dict[str, list[_Sample]] = {}
    with (
        ServerProcess([sys.executable, "-m", "bench.floor"]) as floor_server,
        ServerProcess([sys.executable, "-m", "bench.modbus_ref"]) as modbus_server,
        # A controller each for the two clients: a simulator answers the connection that wrote
        # last, so two clients taking turns on one line could see each other's answers.
        ServerProcess(sim_command(count=2), ready_lines=2) as sim,
        ServerProcess([sys.executable, "-m", "bench.floor", "canned"]) as canned,
        ServerProcess([sys.executable, "-m", "bench.floor", "modbus"]) as mb_canned,
        _placed(pin, [floor_server, modbus_server, sim, canned, mb_canned]) as placement,
        asyncio.Runner() as runner,
    ):
        floor_sock = floor.connect(floor_server.lines[0])
        async_floor = runner.run(floor.async_connect(floor_server.lines[0]))
        mb_sync = modbus_ref.sync_client(modbus_server.lines[0])
        mb_async = runner.run(modbus_ref.async_client(modbus_server.lines[0]))
        mbc_sync = modbus_ref.sync_client(mb_canned.lines[0])
        mbc_async = runner.run(modbus_ref.async_client(mb_canned.lines[0]))
        ours_sync = Client(sim.lines[0])
        ours_async = AsyncClient(sim.lines[1])
        runner.run(ours_async.connect())
        canned_url = f"tcp://{canned.lines[0]}"
        canned_sync = Client(canned_url)
        canned_async = AsyncClient(canned_url)
        runner.run(canned_async.connect())
        contenders: dict[str, tuple[Loop, ServerProcess]] = {
            "raw floor": (
                lambda s: floor.client_loop(floor_sock, seconds=s, limit=_LIMIT),
                floor_server,
            ),
            "asyncio floor": (
                lambda s: runner.run(floor.async_client_loop(async_floor, seconds=s, limit=_LIMIT)),
                floor_server,
            ),
            "pymodbus sync": (
                lambda s: modbus_ref.sync_loop(mb_sync, seconds=s, limit=_LIMIT),
                modbus_server,
            ),
            "pymodbus async": (
                lambda s: runner.run(modbus_ref.async_loop(mb_async, seconds=s, limit=_LIMIT)),
                modbus_server,
            ),
            "robostar sync AA": (_sync_robostar(ours_sync, "AA"), sim),
            "robostar sync AC": (_sync_robostar(ours_sync, "AC"), sim),
            "robostar async AA": (
                lambda s: runner.run(_async_robostar_loop(ours_async, "AA", s)),
                sim,
            ),
            "robostar async AC": (
                lambda s: runner.run(_async_robostar_loop(ours_async, "AC", s)),
                sim,
            ),
            "pymodbus sync, canned": (
                lambda s: modbus_ref.sync_loop(mbc_sync, seconds=s, limit=_LIMIT),
                mb_canned,
            ),
            "pymodbus async, canned": (
                lambda s: runner.run(modbus_ref.async_loop(mbc_async, seconds=s, limit=_LIMIT)),
                mb_canned,
            ),
            "robostar sync AA, canned": (_sync_robostar(canned_sync, "AA"), canned),
            "robostar sync AC, canned": (_sync_robostar(canned_sync, "AC"), canned),
            "robostar async AA, canned": (
                lambda s: runner.run(_async_robostar_loop(canned_async, "AA", s)),
                canned,
            ),
            "robostar async AC, canned": (
                lambda s: runner.run(_async_robostar_loop(canned_async, "AC", s)),
                canned,
            ),
        }
        names = list(contenders)
        try:
            for loop, server in contenders.values():
                _measure(loop, min(seconds, 0.2), server)  # warm-up
            for r in range(rounds):
                order = names[r % len(names) :] + names[: r % len(names)]
                for name in order:
                    loop, server = contenders[name]
                    samples.setdefault(name, []).append(_measure(loop, seconds, server))
        finally:
            floor_sock.close()
            assert async_floor.transport is not None
            async_floor.transport.close()
            mb_sync.close()
            mb_async.close()
            mbc_sync.close()
            mbc_async.close()
            ours_sync.close()
            runner.run(ours_async.close())
            canned_sync.close()
            runner.run(canned_async.close())
    results, rows = _report(samples, seconds, rounds)
    results["placement"] = placement
    return results, rows


def _report(
    samples: dict[str, list[_Sample]], seconds: float, rounds: int
) -> tuple[dict[str, Any], list[Row]]:
    results: dict[str, Any] = {"seconds": seconds, "rounds": rounds, "contenders": {}}
    rows = []
    for name, runs in samples.items():
        floor_name = _floor_of(name)
        floor_samples = samples[floor_name]
        rate_ratio = median(s.rate / f.rate for s, f in zip(runs, floor_samples, strict=True))
        cpu_ratio = median(s.cpu_us / f.cpu_us for s, f in zip(runs, floor_samples, strict=True))
        short = "floor" if floor_name == "raw floor" else "async floor"
        entry = {
            "rate": median(s.rate for s in runs),
            "client_cpu_us": median(s.cpu_us for s in runs),
            "server_cpu_us": median(s.server_us for s in runs),
            "floor": floor_name,
            "rate_vs_floor": rate_ratio,
            "cpu_vs_floor": cpu_ratio,
            "rounds": [
                {"rate": s.rate, "client_cpu_us": s.cpu_us, "server_cpu_us": s.server_us}
                for s in runs
            ],
        }
        results["contenders"][name] = entry
        ours = name.startswith("robostar") and "canned" not in name
        rows.append(
            Row(
                "2 loopback",
                f"{name}: exchanges/s",
                f"{entry['rate']:,.0f} ({rate_ratio:.0%} of {short})",
                f"≥ {RATE_TARGET:.0%} of {short}" if ours else "",
                rate_ratio >= RATE_TARGET if ours else None,
            )
        )
        rows.append(
            Row(
                "2 loopback",
                f"{name}: client CPU/exchange",
                f"{entry['client_cpu_us']:.0f} µs ({cpu_ratio:.2f}× {short};"
                f" server {entry['server_cpu_us']:.0f} µs)",
                f"≤ {CPU_TARGET}× {short}" if ours else "",
                cpu_ratio <= CPU_TARGET if ours else None,
            )
        )
    mb = results["contenders"]["pymodbus sync"]["rate"]
    for name in ("robostar sync AA", "robostar async AA"):
        results["contenders"][name]["vs_pymodbus_sync"] = results["contenders"][name]["rate"] / mb
    rows += _against_pymodbus(samples, results)
    return results, rows


def _floor_of(name: str) -> str:
    """The floor a contender is measured against: asyncio's for an asyncio client."""
    return "asyncio floor" if "async" in name else "raw floor"


PYMODBUS_TARGETS = {"sync": 1.0, "async": 1.2}
"""Issue #18: robostar ÷ pymodbus exchange rate, each against its minimal canned responder."""


def _against_pymodbus(samples: dict[str, list[_Sample]], results: dict[str, Any]) -> list[Row]:
    """Issue #18's figures: each a median of per-round ratios (a round measures both)."""
    rows = []
    for kind, target in PYMODBUS_TARGETS.items():
        ours = samples[f"robostar {kind} AA, canned"]
        theirs = samples[f"pymodbus {kind}, canned"]
        pairs = list(zip(ours, theirs, strict=True))
        rate = median(a.rate / b.rate for a, b in pairs)
        cpu = median(a.cpu_us / b.cpu_us for a, b in pairs)
        results[f"vs_pymodbus_{kind}"] = {"rate": rate, "client_cpu": cpu}
        rows.append(
            Row(
                "2 loopback",
                f"robostar ÷ pymodbus {kind}, canned: rate",
                f"{rate:.2f}×",
                f"≥ {target:.1f}×",
                rate >= target,
            )
        )
        rows.append(
            Row(
                "2 loopback",
                f"robostar ÷ pymodbus {kind}, canned: client CPU",
                f"{cpu:.2f}×",
                "< 1.0×",
                cpu < 1.0,
            )
        )
        # _report's own per-round ratio against the matching floor, taken there
        entry = results["contenders"][f"robostar {kind} AA, canned"]
        floor_name, to_floor = entry["floor"], entry["cpu_vs_floor"]
        results[f"vs_floor_{kind}"] = {"client_cpu": to_floor, "floor": floor_name}
        rows.append(
            Row(
                "2 loopback",
                f"robostar {kind} AA, canned: client CPU ÷ the {floor_name}'s",
                f"{to_floor:.2f}×",
                f"≤ {CPU_TARGET}×",
                to_floor <= CPU_TARGET,
            )
        )
    sim = samples["robostar sync AA"]
    server = samples["pymodbus sync"]
    ratio = median(a.server_us / b.server_us for a, b in zip(sim, server, strict=True))
    results["sim_vs_pymodbus_server"] = ratio
    rows.append(
        Row(
            "2 loopback",
            "simulator CPU per AA ÷ pymodbus server per request",
            f"{ratio:.2f}×",
            "≤ 1.0×",
            ratio <= 1.0,
        )
    )
    return rows
