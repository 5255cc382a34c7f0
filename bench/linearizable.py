"""The cost of linearizable reads through the line server (figures, never asserted):
``python -m bench.linearizable [SECONDS]``.

1. Added latency: AA (status) and GR (a global integer) p50/p99 on loopback, straight to a TCP
   simulator (a process of its own) vs through the line server's N1 face and through
   ``serve://``. Every read through the server is linearizable: answered by a wire exchange
   that began after it arrived.
2. Many hosts, one slow line: 16 hosts each polling AA at 20 Hz through the N1 face of one
   line to a simulator paced at 9600 baud (then 115200), the poller running as configured by
   default, and one host writing (CB) every 0.25 s; the simulator, the server and the hosts
   each in a process of their own. Reported: the hosts' AA latency p50/p99 in
   AA exchange times (one AA straight to the same paced simulator, p50), the write's latency,
   and the coalescing factor: AAs on the wire (counted with ``Line.on_exchange``) per AA the
   hosts asked for. Also in exchanges: how many other exchanges ended while a write waited (the
   one on the wire when it came: 1), and while a read waited (that one, writes ahead, its
   flight); and what the push faces see meanwhile: the model's positions refreshed per second,
   their mean age, and the stale fraction (of samples taken every 20 ms, those not good).
   At 9600 baud, also with the line's ``poll_share`` at 0.5, 0.25 and 0.1 (the default: 1).
   The robot rests (servo on, homed, still: a cell waiting on its robot), so the status
   vouches for its positions and the poller reads them every ``rest_interval`` only; at 9600
   baud also with the servo off (positions read every poll cycle, as the status cannot vouch
   for an arm that can be pushed by hand) and with channel 1 moving to and fro all along
   (driven over a connection of its own, as from the pendant).
"""

from __future__ import annotations

import asyncio
import bisect
import contextlib
import dataclasses
import multiprocessing
import subprocess
import sys
import time
from collections.abc import Awaitable, Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from bench.measure import percentile
from robostar import AsyncClient
from robostar.commands.base import Command
from robostar.commands.status import ReadPosition, ReadStatus
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.model import Quality

SAMPLES = 300
HOSTS = 16
HOST_HZ = 20.0
WRITE_EVERY = 0.25


@contextlib.contextmanager
def _simulator(baud: int | None = None) -> Iterator[str]:
    """``python -m robostar.sim`` on a free loopback port, in a process of its own (paced at
    ``baud`` when given): its URL."""
    args = [sys.executable, "-m", "robostar.sim", "--listen", "127.0.0.1:0"]
    if baud is not None:
        args += ["--baud", str(baud)]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
    try:
        assert proc.stdout is not None
        url = proc.stdout.readline().strip()
        if not url.startswith("tcp://"):
            raise RuntimeError(f"the simulator did not start: {url!r}")
        yield url
    finally:
        proc.terminate()
        proc.wait(10)


def _ms(values: list[float], q: float) -> float:
    return percentile(values, q) * 1e3


async def _timed(call: Callable[[], Awaitable[Any]], n: int = SAMPLES) -> list[float]:
    out = []
    for _ in range(n):
        t = time.perf_counter()
        await call()
        out.append(time.perf_counter() - t)
    return out


def _server_config(url: str) -> ServeConfig:
    return ServeConfig(
        lines=(LineConfig("cell", url),),
        faces={
            "n1": {"lines": {"cell": "127.0.0.1:0"}, "max_clients": 32},
            "api": {"listen": "127.0.0.1:0"},
        },
    )


async def added_latency() -> None:
    rows: dict[str, dict[str, list[float]]] = {}
    with _simulator() as sim_url:
        urls = {"direct": sim_url}
        async with LineServer(_server_config(sim_url)) as server:
            n1_host, n1_port = server.faces["n1"].addresses["cell"]  # type: ignore[attr-defined]
            api_host, api_port = server.faces["api"].address  # type: ignore[attr-defined]
            urls["N1 face"] = f"tcp://{n1_host}:{n1_port}"
            urls["serve://"] = f"serve://{api_host}:{api_port}/cell"
            for label, url in urls.items():
                async with AsyncClient(url) as client:
                    await client.status()
                    rows[label] = {
                        "AA": await _timed(client.status),
                        "GR": await _timed(lambda c=client: c.read_global_int(7)),
                    }
    print("1. linearizable reads, loopback TCP simulator (ms)")
    for what in ("AA", "GR"):
        base = rows["direct"][what]
        for label, by_command in rows.items():
            values = by_command[what]
            line = f"  {what} {label:<9} p50 {_ms(values, 50):7.3f}  p99 {_ms(values, 99):7.3f}"
            if label != "direct":
                line += f"   added p50 {_ms(values, 50) - _ms(base, 50):+.3f}"
                line += f" p99 {_ms(values, 99) - _ms(base, 99):+.3f}"
            print(line)


async def _aa_exchange_time(url: str) -> float:
    """p50 of one AA straight to the simulator at ``url`` (seconds)."""
    async with AsyncClient(url) as client:
        await client.status()
        return percentile(await _timed(client.status, 50), 50)


Timed = list[tuple[float, float]]
"""(``time.time()`` at the call, latency in seconds) per operation."""


def _hosts(url: str, seconds: float, spread: bool) -> tuple[Timed, Timed, int]:
    """In a process of its own (the hosts are other programs, on other machines): HOSTS hosts
    polling AA at HOST_HZ and one writing CB every WRITE_EVERY, for ``seconds``; the reads'
    and the writes' latencies and the count of failed reads."""
    return asyncio.run(_host_load(url, seconds, spread))


async def _host_load(url: str, seconds: float, spread: bool) -> tuple[Timed, Timed, int]:
    reads: Timed = []
    writes: Timed = []
    errors = [0]
    end = time.monotonic() + seconds

    async def poller(phase: float) -> None:
        async with AsyncClient(url, timeout=10.0) as client:
            next_at = time.monotonic() + phase
            while time.monotonic() < end:
                at, t = time.time(), time.perf_counter()
                try:
                    await client.status()
                    reads.append((at, time.perf_counter() - t))
                except Exception:
                    errors[0] += 1
                next_at += 1 / HOST_HZ
                await asyncio.sleep(max(0.0, next_at - time.monotonic()))

    async def writer() -> None:
        async with AsyncClient(url, timeout=10.0) as client:
            speed = 100
            while time.monotonic() < end:
                speed = 100 if speed == 200 else 200
                at, t = time.time(), time.perf_counter()
                await client.set_speed(1, speed)
                writes.append((at, time.perf_counter() - t))
                await asyncio.sleep(WRITE_EVERY)

    # aligned: every host asks at the same instant (the worst case); spread: evenly apart
    # over a period, as programs on separate machines started at different times would
    phases = [n / (HOSTS * HOST_HZ) if spread else 0.0 for n in range(HOSTS)]
    await asyncio.gather(*(poller(phase) for phase in phases), writer())
    return reads, writes, errors[0]


def _ended_during(ends: list[float], timed: Timed) -> list[int]:
    """Per operation: the exchanges that ended on the line while it waited (its own included)."""
    between = bisect.bisect_left
    return [between(ends, at + took) - between(ends, at) for at, took in timed]


async def _watch_model(line: Any, samples: list[tuple[bool, float]]) -> None:
    """Every 20 ms, channel 1's position as the push faces see it: (good?, age in seconds)."""
    while True:
        await asyncio.sleep(0.02)
        sample = line.model.get("ch1/position")
        if sample is not None:
            samples.append((sample.quality is Quality.GOOD, time.time() - sample.at))


ROBOT_STATES = ("rests", "servo off", "moving")


async def _prepare(url: str, robot: str) -> None:
    """Put the simulator's robots in the state ``robot`` names (see ROBOT_STATES)."""
    if robot == "servo off":
        return
    async with AsyncClient(url, timeout=10.0) as client:
        for channel in (1, 2):
            await client.servo(channel, True)
            await client.home(channel)
        for channel in (1, 2):
            await client.wait_stopped(channel, timeout=60.0)


async def _to_and_fro(url: str, stop: asyncio.Event) -> None:
    """Channel 1's first axis 30 degrees one way, then back, until ``stop`` (at the end of a
    move: a move cancelled on the wire is a move of unknown outcome)."""
    async with AsyncClient(url, timeout=10.0) as client:
        step = 30.0
        while not stop.is_set():
            await client.move_by(1, (step, 0.0, 0.0, 0.0), wait=True, timeout=30.0)
            step = -step


async def many_hosts(
    baud: int,
    seconds: float,
    poll_share: float | None = None,
    robot: str = "rests",
    spread: bool = False,
) -> None:
    with _simulator(baud) as sim_url:
        await _prepare(sim_url, robot)
        unit = await _aa_exchange_time(sim_url)
        config = _server_config(sim_url)
        if poll_share is not None:
            config = dataclasses.replace(
                config, lines=(dataclasses.replace(config.lines[0], poll_share=poll_share),)
            )
        async with LineServer(config) as server:
            line = server.lines["cell"]
            await line.wait_polled(timeout=30)
            wire_aas = [0]
            positions = [0]
            ends: list[float] = []

            def count(command: Command[Any], outcome: Any, who: object) -> None:
                ends.append(time.time())
                if isinstance(command, ReadStatus):
                    wire_aas[0] += 1
                elif isinstance(command, ReadPosition) and command.channel == 1:
                    positions[0] += 1

            line.on_exchange(count)
            host, port = server.faces["n1"].addresses["cell"]  # type: ignore[attr-defined]
            polls_before = line.model.updates
            seen: list[tuple[bool, float]] = []
            watcher = asyncio.create_task(_watch_model(line, seen))
            stop_moving = asyncio.Event()
            mover = (
                asyncio.create_task(_to_and_fro(sim_url, stop_moving))
                if robot == "moving"
                else None
            )
            with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
                hosts = asyncio.get_running_loop().run_in_executor(
                    pool, _hosts, f"tcp://{host}:{port}", seconds, spread
                )
                timed_reads, timed_writes, errors = await hosts
            watcher.cancel()
            if mover is not None:
                stop_moving.set()
                await mover
            confirmed = line.feed.witness.confirmed
            wire = wire_aas[0]
            updates = line.model.updates - polls_before
            share = line.config.poll_share
    reads = [took for _, took in timed_reads]
    writes = [took for _, took in timed_writes]
    asked = len(reads) + errors
    read50, read99 = percentile(reads, 50) / unit, percentile(reads, 99) / unit
    write50, write99 = percentile(writes, 50) / unit, percentile(writes, 99) / unit
    read_waits = _ended_during(ends, timed_reads)
    write_waits = _ended_during(ends, timed_writes)
    stale = sum(1 for good, _ in seen if not good) / max(1, len(seen))
    mean_age = sum(age for _, age in seen) / max(1, len(seen))
    print(
        f"  {baud:>6} baud, robot {robot}, hosts {'spread' if spread else 'aligned'},"
        f" poll_share {share:g}: AA exchange {unit * 1e3:6.2f} ms;"
        f" hosts' AA p50 {read50:5.2f}, p99 {read99:5.2f} AA times ({_ms(reads, 99):.1f} ms);"
        f" write p50 {write50:5.2f}, p99 {write99:5.2f} AA times;"
        f" {asked / seconds:.0f} host AAs/s, {wire / seconds:.0f} wire AAs/s,"
        f" coalescing factor {wire / max(1, asked):.3f} wire AA per host AA;"
        f" model {updates / seconds:.0f} values/s; errors {errors}\n"
        f"      exchanges ended while waiting (own included): read p99"
        f" {percentile(read_waits, 99):.0f} max {max(read_waits, default=0)},"
        f" write p99 {percentile(write_waits, 99):.0f} max {max(write_waits, default=0)};"
        f" ch1 positions (XY + angles) {positions[0] / seconds:.1f}/s, mean age"
        f" {mean_age * 1e3:.0f} ms, stale fraction {stale:.3f};"
        f" values confirmed by status {confirmed / seconds:.0f}/s"
    )


async def main() -> None:
    seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 5.0
    await added_latency()
    print(
        f"2. {HOSTS} hosts polling AA at {HOST_HZ:g} Hz through the N1 face of one paced line,"
        f" a CB every {WRITE_EVERY:g} s, {seconds:g} s each"
    )
    with contextlib.suppress(KeyboardInterrupt):
        for robot in ROBOT_STATES:
            await many_hosts(9600, seconds, robot=robot)
        for share in (0.5, 0.25, 0.1):
            await many_hosts(9600, seconds, share, robot="moving")
        await many_hosts(9600, seconds, spread=True)
        await many_hosts(115200, seconds)
        await many_hosts(115200, seconds, spread=True)


if __name__ == "__main__":
    asyncio.run(main())
