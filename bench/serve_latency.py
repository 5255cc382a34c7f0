"""The line server's cost and reach (figures, never asserted): ``python -m bench.serve_latency``.

1. Added latency: AA (status) p50/p99 straight to a simulator vs through the line server's N1
   face (every read sent on: linearizable) and answered from its model (``n1.max_age = 1``).
2. Model update rate: values stored per second by one line polling as fast as it can.
3. Reach: 64 simulated lines polled at 10 Hz in this one process; the rate achieved is the
   share of the asked poll cycles that completed.
"""

from __future__ import annotations

import asyncio
import sys
import time

from bench.measure import percentile
from robostar import AsyncClient
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.sim import SimConfig, VirtualController
from robostar.sim.listeners import SimServer

SAMPLES = 300


async def _latencies(client: AsyncClient, n: int = SAMPLES) -> list[float]:
    out = []
    for _ in range(n):
        t = time.perf_counter()
        await client.status()
        out.append(time.perf_counter() - t)
    return out


def _fmt(name: str, values: list[float]) -> str:
    p50, p99 = percentile(values, 50) * 1e3, percentile(values, 99) * 1e3
    return f"  {name:<34} p50 {p50:7.3f} ms   p99 {p99:7.3f} ms"


async def added_latency() -> None:
    sim = SimServer(VirtualController(SimConfig())).start()
    try:
        async with AsyncClient(sim.url) as direct:
            straight = await _latencies(direct)
        results = {}
        for label, max_age in (("through server (sent on)", None), ("through server (model)", 1.0)):
            # reads are linearizable (sent on) unless the face accepts older values (n1.max_age)
            line = LineConfig("cell", sim.url, poll_interval=0.05)
            n1 = {"lines": {"cell": "127.0.0.1:0"}, "max_age": max_age}
            config = ServeConfig(lines=(line,), faces={"n1": n1})
            async with LineServer(config) as server:
                host, port = server.faces["n1"].addresses["cell"]  # type: ignore[attr-defined]
                async with AsyncClient(f"tcp://{host}:{port}") as client:
                    results[label] = await _latencies(client)
    finally:
        sim.close()
    print("1. AA latency, TCP to a simulator")
    print(_fmt("direct", straight))
    for label, values in results.items():
        print(_fmt(label, values))
    added = percentile(results["through server (sent on)"], 50) - percentile(straight, 50)
    print(f"  added by the server (p50, sent on): {added * 1e3:.3f} ms")


async def model_rate(seconds: float = 3.0) -> None:
    line = LineConfig("cell", "sim://", poll_interval=0.001, slow_interval=0.1)
    async with LineServer(ServeConfig(lines=(line,), faces={})) as server:
        model = server.lines["cell"].model
        start, t = model.updates, time.perf_counter()
        await asyncio.sleep(seconds)
        rate = (model.updates - start) / (time.perf_counter() - t)
    print(f"2. model update rate, one sim:// line polled flat out: {rate:,.0f} values/s")


async def reach(lines: int = 64, hz: float = 10.0, seconds: float = 5.0) -> None:
    configs = tuple(
        LineConfig(f"l{i}", "sim://", poll_interval=1 / hz, slow_interval=1.0) for i in range(lines)
    )
    async with LineServer(ServeConfig(lines=configs, faces={})) as server:
        polls = {name: 0 for name in server.lines}
        stamps = {name: line.health.last_poll for name, line in server.lines.items()}
        end = time.monotonic() + seconds
        t0 = time.process_time()
        while time.monotonic() < end:
            await asyncio.sleep(0.01)
            for name, line in server.lines.items():
                if line.health.last_poll != stamps[name]:
                    stamps[name] = line.health.last_poll
                    polls[name] += 1
        cpu = time.process_time() - t0
    asked = lines * hz * seconds
    done = sum(polls.values())
    print(
        f"3. {lines} sim:// lines at {hz:g} Hz for {seconds:g} s in one process:"
        f" {done}/{asked:.0f} poll cycles = {done / asked:.1%} of the asked rate,"
        f" CPU {cpu / seconds:.0%} of one core (simulators included)"
    )


async def main() -> None:
    await added_latency()
    await model_rate()
    await reach(int(sys.argv[1]) if len(sys.argv) > 1 else 64)


if __name__ == "__main__":
    asyncio.run(main())
