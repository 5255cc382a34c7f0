"""Item 4, jog keepalive under load: BF gaps while two threads poll as fast as they can.

One blocking client jogs channel 1 (BE, then BF every 200 ms from the jog's thread) while two
other threads call ``status()`` and ``position(1)`` back to back on the same client. The gaps
are measured where they start, at the transport: from BE to the first BF and between BFs, by
their write time. The simulator enforces the 500 ms limit itself (it stops a jog that misses
it, and the next BF is then refused), so a jog that ends without error also says no gap
passed 500 ms at the controller.

To tell where a late BF lost its time, each BF's gap is split in two: from the previous BF's
call to this one's (the jog thread waking on its schedule: the OS and the GIL) and from the
call to the write (waiting for the exchange in progress, the lock hand-over, encoding).
"""

from __future__ import annotations

import itertools
import threading
import time
from typing import Any

from bench.counting import CountingTransport
from bench.measure import Row, percentile
from bench.procs import ServerProcess, sim_command
from robostar import Client
from robostar.commands.base import Command
from robostar.commands.motion import JogContinue
from robostar.errors import RobostarError
from robostar.transport import transport_for_url

__all__ = ["run"]

TARGET_MAX = 0.250
INTERVAL = 0.2


def run(*, seconds: float = 60.0) -> tuple[dict[str, Any], list[Row]]:
    counts = {"status": 0, "position": 0}
    errors: list[BaseException] = []
    jog_error: str | None = None
    with ServerProcess(sim_command()) as sim:
        transport = CountingTransport(transport_for_url(sim.lines[0]))
        with Client(transport, keepalive=INTERVAL) as client:
            stop = threading.Event()

            def poll(name: str) -> None:
                call = client.status if name == "status" else lambda: client.position(1)
                try:
                    while not stop.is_set():
                        call()
                        counts[name] += 1
                except BaseException as exc:  # reported below
                    errors.append(exc)

            threads = [
                threading.Thread(target=poll, args=(name,), name=f"bench {name}") for name in counts
            ]
            # Note when the jog thread calls in with each BF: Client.jog hands the Jog the
            # client's _urgent_call, so an instance attribute set first is what it calls.
            called: list[float] = []
            urgent = client._urgent_call

            def traced(command: Command[None]) -> None:
                if isinstance(command, JogContinue):
                    called.append(time.monotonic())
                urgent(command)

            client._urgent_call = traced  # type: ignore[method-assign]
            start = time.monotonic()
            try:
                with client.jog(1, axis=1, direction="+"):
                    for thread in threads:
                        thread.start()
                    time.sleep(seconds)
                    stop.set()
                    for thread in threads:
                        thread.join()
            except RobostarError as exc:
                jog_error = str(exc)
            finally:
                stop.set()
            elapsed = time.monotonic() - start
    if errors:
        raise RuntimeError(f"a polling thread failed: {errors[0]!r}") from errors[0]
    times = transport.keepalive_times
    gaps = [b - a for a, b in itertools.pairwise(times)]
    worst = max(gaps, default=float("nan"))
    p99 = percentile(gaps, 99)
    bf_writes = times[1:]  # times[0] is BE
    wake_gaps = [b - a for a, b in itertools.pairwise(called)]
    call_to_write = [w - c for c, w in zip(called, bf_writes, strict=False)]
    results: dict[str, Any] = {
        "seconds": seconds,
        "interval": INTERVAL,
        "keepalives": len(times),
        "gap_max": worst,
        "gap_p99": p99,
        "gap_median": percentile(gaps, 50),
        "polls_per_s": {k: v / elapsed for k, v in counts.items()},
        "jog_error": jog_error,
        "wake_gap_max": max(wake_gaps, default=float("nan")),
        "call_to_write_max": max(call_to_write, default=float("nan")),
        "call_to_write_p99": percentile(call_to_write, 99),
    }
    polls = sum(counts.values()) / elapsed
    rows = [
        Row(
            "4 jog",
            f"BF gap max ({seconds:g} s, {polls:,.0f} polls/s beside)",
            f"{worst * 1000:.0f} ms",
            f"< {TARGET_MAX * 1000:.0f} ms",
            worst < TARGET_MAX and jog_error is None,
        ),
        Row("4 jog", "BF gap p99", f"{p99 * 1000:.0f} ms"),
        Row(
            "4 jog",
            "BF gap split: thread wake gap max; call to write max",
            f"{results['wake_gap_max'] * 1000:.0f} ms;"
            f" {results['call_to_write_max'] * 1000:.1f} ms",
        ),
    ]
    if jog_error is not None:
        rows.append(Row("4 jog", "jog ended with an error", jog_error, "none", False))
    return results, rows
