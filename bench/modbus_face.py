"""The Modbus face's figures (printed, never asserted): ``python -m bench.modbus_face``.

A PLC (pymodbus's asyncio client, in a process of its own) polls the whole register map every
10 ms on a fixed schedule: the header and every block's health, the three channels, alarms and
I/O, the globals, the discrete inputs and the handshake's results, 8 requests a cycle. Printed:

1. the answer time of each request (send to answer) and of each whole cycle, p50 / p99 / max,
   and the share of the cycles that started on time;
2. the line's exchanges per second, by command, over the same time without the PLC, then with
   it: reads come from the model, so the PLC's cycle must not change the line's load (the
   poller's slow reads come once a second, so a window holds one more or one fewer of them);
3. for reference, the same PLC loop against pymodbus's own server (``bench.modbus_ref``: a
   plain datastore, each request reading ``min(count, 99)`` holding registers): what pymodbus
   and this machine cost without the face.

The line server runs in this process with one ``sim://`` line (its default poll intervals)
and the face on a free loopback port.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import subprocess
import sys
import time
from collections import Counter
from typing import Any, TypeVar

from bench.measure import percentile
from robostar.client.aio import AsyncClient
from robostar.client.exchange import Progress
from robostar.commands.base import Command
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.modbus.layout import BLOCKS, DI, HR, IR

R = TypeVar("R")
GLOBALS = {"int": {"first": 0, "count": 16}, "float": {"first": 0, "count": 8}}
"""The globals the bench's map shows (the face reads them once a second)."""

_READS: list[tuple[str, int, int]] = [
    ("ir", 0, IR.HEALTH + 2 * len(BLOCKS)),
    ("ir", 100, 38),
    ("ir", 200, 38),
    ("ir", 300, 38),
    ("ir", IR.ALARM_COUNT, IR.OUTPUTS + 5 - IR.ALARM_COUNT),
    ("ir", IR.GLOBAL_INTS, 2 * 16 + 0),
    ("di", 0, DI.SIZE),
    ("hr", HR.WRITABLE, HR.SIZE - HR.WRITABLE),
]
"""The whole map, as a PLC would read it: (table, address, count); floats at 1200 too."""
_READS.append(("ir", IR.GLOBAL_FLOATS, 2 * 8))


async def _plc(
    host: str, port: int, seconds: float, cycle: float, reference: bool
) -> dict[str, Any]:
    from pymodbus.client import AsyncModbusTcpClient

    client = AsyncModbusTcpClient(host, port=port, timeout=3)
    await client.connect()
    calls = {
        "ir": client.read_input_registers,
        "di": client.read_discrete_inputs,
        "hr": client.read_holding_registers,
    }
    requests: list[float] = []
    cycles: list[float] = []
    late = errors = 0
    loop = asyncio.get_running_loop()
    start = loop.time()
    n = 0
    while loop.time() - start < seconds:
        due = start + n * cycle
        now = loop.time()
        if now < due:
            await asyncio.sleep(due - now)
        elif now - due > cycle:
            late += 1
        began = time.perf_counter()
        for table, address, count in _READS:
            sent = time.perf_counter()
            if reference:
                answer = await client.read_holding_registers(0, count=min(count, 99))
            else:
                answer = await calls[table](address, count=count)
            requests.append(time.perf_counter() - sent)
            if answer.isError():
                errors += 1
        cycles.append(time.perf_counter() - began)
        n += 1
    client.close()
    return {"requests": requests, "cycles": cycles, "late": late, "errors": errors, "n": n}


def plc_main(address: str, seconds: float, cycle: float, reference: bool = False) -> None:
    """The PLC process: poll, then print its figures as one JSON line."""
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    host, port = address.rsplit(":", 1)
    figures = asyncio.run(_plc(host, int(port), seconds, cycle, reference))
    print(json.dumps(figures), flush=True)


def _reference(seconds: float, cycle: float) -> dict[str, Any]:
    """The PLC loop against pymodbus's own server, each in a process of its own."""
    server = subprocess.Popen(
        [sys.executable, "-m", "bench.modbus_ref"], stdout=subprocess.PIPE, text=True
    )
    try:
        assert server.stdout is not None
        address = server.stdout.readline().strip()
        command = [sys.executable, "-m", "bench.modbus_face", "--plc", address, "--reference"]
        command += ["--seconds", str(seconds), "--cycle-ms", str(cycle * 1000)]
        child = subprocess.run(command, stdout=subprocess.PIPE, text=True, check=True)
        figures: dict[str, Any] = json.loads(child.stdout.strip().splitlines()[-1])
        return figures
    finally:
        server.terminate()
        server.wait()


_SENT: Counter[str] = Counter()
"""Exchanges the line ran, by command code."""


class _CountingClient(AsyncClient):
    async def execute(self, command: Command[R], progress: Progress | None = None) -> R:
        _SENT[command.CODE] += 1
        return await super().execute(command, progress)


def _client(config: LineConfig) -> AsyncClient:
    return _CountingClient(config.url, timeout=config.timeout)


async def _exchanges_per_second(seconds: float) -> dict[str, float]:
    """The line's exchanges per second over ``seconds``, by command code."""
    _SENT.clear()
    started = time.perf_counter()
    await asyncio.sleep(seconds)
    elapsed = time.perf_counter() - started
    return {code: count / elapsed for code, count in sorted(_SENT.items())}


async def _run(seconds: float, cycle: float) -> dict[str, Any]:
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://"),),
        faces={"modbus": {"lines": {"cell1": "127.0.0.1:0"}, "globals": GLOBALS}},
    )
    async with LineServer(config, client_factory=_client) as server:
        await server.line("cell1").wait_polled()
        await asyncio.sleep(1.0)  # the globals read once, a slow cycle done
        quiet = await _exchanges_per_second(seconds - 1.0)  # the same window as with the PLC
        host, port = server.faces["modbus"].addresses["cell1"]  # type: ignore[attr-defined]
        child = await asyncio.create_subprocess_exec(
            sys.executable,
            "-m",
            "bench.modbus_face",
            "--plc",
            f"{host}:{port}",
            "--seconds",
            str(seconds),
            "--cycle-ms",
            str(cycle * 1000),
            stdout=subprocess.PIPE,
        )
        await asyncio.sleep(0.5)  # the child's start-up, not counted
        polled = await _exchanges_per_second(seconds - 1.0)
        out, _ = await child.communicate()
        figures: dict[str, Any] = json.loads(out.decode().strip().splitlines()[-1])
        figures["quiet"] = quiet
        figures["polled"] = polled
        return figures


def _ms(values: list[float], q: float) -> str:
    return f"{percentile(values, q) * 1000:.2f}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--cycle-ms", type=float, default=10.0)
    parser.add_argument("--plc", metavar="HOST:PORT", help=argparse.SUPPRESS)
    parser.add_argument("--reference", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    cycle = args.cycle_ms / 1000
    if args.plc:
        plc_main(args.plc, args.seconds, cycle, args.reference)
        return 0
    f = asyncio.run(_run(args.seconds, cycle))
    print(f"PLC: {len(_READS)} requests every {args.cycle_ms:g} ms for {args.seconds:g} s")
    _print("the Modbus face", f, args.seconds, cycle)
    quiet, polled = f["quiet"], f["polled"]
    print(
        f"  line exchanges/s: {sum(quiet.values()):.1f} without the PLC,"
        f" {sum(polled.values()):.1f} with it; by command (without / with):"
    )
    for code in sorted(quiet.keys() | polled.keys()):
        print(f"    {code}  {quiet.get(code, 0.0):5.1f} / {polled.get(code, 0.0):5.1f}")
    reference = _reference(args.seconds, cycle)
    _print("pymodbus's own server (reference)", reference, args.seconds, cycle)
    return 0


def _print(title: str, f: dict[str, Any], seconds: float, cycle: float) -> None:
    requests, cycles = f["requests"], f["cycles"]
    print(title)
    print(
        f"  request answer time ms: p50 {_ms(requests, 50)}  p99 {_ms(requests, 99)}"
        f"  max {max(requests) * 1000:.2f}  ({len(requests)} requests, {f['errors']} errors)"
    )
    print(
        f"  whole cycle ms:         p50 {_ms(cycles, 50)}  p99 {_ms(cycles, 99)}"
        f"  max {max(cycles) * 1000:.2f}"
    )
    expected = int(seconds / cycle)
    print(f"  cycles run {f['n']} of {expected}, {f['late']} started over a cycle late")


if __name__ == "__main__":
    sys.exit(main())
