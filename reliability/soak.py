"""The soak: many exchanges over loopback TCP against the simulator, counting every error.

The simulator runs as its own process (``python -m robostar.sim``), as a user would run it, so
the client's and the simulator's memory are measured apart (resident set size from ``/proc``).
Exchanges cycle through reads and writes of every kind, and each written global value is read
back and compared, so a wrong answer counts as an error, not only a raised one.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robostar.client import Client
from robostar.commands.base import Command
from robostar.commands.control import ReadSpeed, SetSpeed
from robostar.commands.files import FileExists
from robostar.commands.io import ReadOutputs, SetOutput
from robostar.commands.status import ReadAlarms, ReadInfo, ReadPosition, ReadStatus
from robostar.commands.system import ReadLastError
from robostar.commands.variables import (
    ReadGlobalFloat,
    ReadGlobalInt,
    WriteGlobalFloat,
    WriteGlobalInt,
)
from robostar.errors import RobostarError
from robostar.protocol.fields import FileName

__all__ = ["SoakReport", "rss_kb", "run_soak", "sim_process"]

_START_TIMEOUT = 20.0


@contextlib.contextmanager
def sim_process(
    state_dir: str | os.PathLike[str] | None = None, extra: Sequence[str] = ()
) -> Iterator[tuple[subprocess.Popen[str], str]]:
    """Run ``python -m robostar.sim`` on a free loopback port; yields (process, tcp URL)."""
    argv = [sys.executable, "-m", "robostar.sim", "--listen", "127.0.0.1:0", *extra]
    if state_dir is not None:
        argv += ["--state", str(state_dir)]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        url = proc.stdout.readline().strip()
        if not url.startswith("tcp://"):
            proc.kill()
            _, err = proc.communicate(timeout=_START_TIMEOUT)
            raise RuntimeError(f"the simulator did not start: {url!r} {err!r}")
        yield proc, url
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=_START_TIMEOUT)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def rss_kb(pid: int | None = None) -> int:
    """Resident set size of a process (this one by default), in KiB, from /proc."""
    path = Path(f"/proc/{pid or os.getpid()}/status")
    for line in path.read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError(f"no VmRSS in {path}")


@dataclass(frozen=True)
class Step:
    """One exchange of the cycle; ``expect`` (given the cycle number) checks the result."""

    make: Callable[[int], Command[Any]]
    expect: Callable[[int, Any], bool] | None = None


_DEMO = FileName("DEMO", "JOB")
CYCLE: tuple[Step, ...] = (
    Step(lambda i: ReadStatus()),
    Step(lambda i: WriteGlobalInt(7, i % 100_000)),
    Step(lambda i: ReadGlobalInt(7), lambda i, r: r == i % 100_000),
    Step(lambda i: ReadPosition(1)),
    Step(lambda i: SetSpeed(1, i % 1001)),
    Step(lambda i: ReadSpeed(1), lambda i, r: r == i % 1001),
    Step(lambda i: WriteGlobalFloat(8, (i % 10_000) / 8)),
    Step(lambda i: ReadGlobalFloat(8), lambda i, r: abs(r - (i % 10_000) / 8) < 1e-3),
    Step(lambda i: SetOutput(1, i % 16, bool(i % 2))),
    Step(lambda i: ReadOutputs(1), lambda i, r: r.contacts[i % 16] == bool(i % 2)),
    Step(lambda i: FileExists(1, _DEMO), lambda i, r: r is True),
    Step(lambda i: ReadAlarms(), lambda i, r: r == ()),
    Step(lambda i: ReadInfo()),
    Step(lambda i: ReadLastError()),
)
"""Reads and writes of every single-packet kind, and a multi-packet read (AB, empty: END)."""


@dataclass
class SoakReport:
    exchanges: int = 0
    errors: Counter[str] = field(default_factory=Counter)
    wrong: int = 0
    seconds: float = 0.0
    client_rss_kb: list[tuple[int, int]] = field(default_factory=list)
    sim_rss_kb: list[tuple[int, int]] = field(default_factory=list)
    first_errors: list[str] = field(default_factory=list)

    @staticmethod
    def _growth(samples: list[tuple[int, int]]) -> int | None:
        # From the first sample after warm-up (10 % in) to the last.
        if len(samples) < 2:
            return None
        warm = samples[min(len(samples) - 1, max(1, len(samples) // 10))]
        return samples[-1][1] - warm[1]

    def as_json(self) -> dict[str, Any]:
        return {
            "exchanges": self.exchanges,
            "errors": sum(self.errors.values()),
            "errors_by_type": dict(self.errors),
            "wrong_results": self.wrong,
            "seconds": round(self.seconds, 1),
            "exchanges_per_second": round(self.exchanges / self.seconds) if self.seconds else None,
            "client_rss_growth_kb_after_warmup": self._growth(self.client_rss_kb),
            "sim_rss_growth_kb_after_warmup": self._growth(self.sim_rss_kb),
            "client_rss_kb": self.client_rss_kb,
            "sim_rss_kb": self.sim_rss_kb,
            "first_errors": self.first_errors[:20],
        }


def run_soak(
    url: str,
    exchanges: int,
    *,
    sim_pid: int | None = None,
    samples: int = 50,
    timeout: float = 2.0,
    progress: Callable[[int], None] | None = None,
) -> SoakReport:
    """Run ``exchanges`` exchanges on one client at ``url``; errors are counted, not raised."""
    report = SoakReport()
    every = max(exchanges // samples, 1)
    start = time.perf_counter()
    with Client(url, timeout=timeout) as client:
        for n in range(exchanges):
            cycle, index = divmod(n, len(CYCLE))
            step = CYCLE[index]
            try:
                result = client.execute(step.make(cycle))
            except RobostarError as exc:
                report.errors[type(exc).__name__] += 1
                report.first_errors.append(f"#{n}: {exc!r}")
            else:
                if step.expect is not None and not step.expect(cycle, result):
                    report.wrong += 1
                    report.first_errors.append(f"#{n}: wrong result {result!r}")
            if n % every == 0 or n == exchanges - 1:
                report.client_rss_kb.append((n, rss_kb()))
                if sim_pid is not None:
                    report.sim_rss_kb.append((n, rss_kb(sim_pid)))
                if progress is not None:
                    progress(n)
    report.exchanges = exchanges
    report.seconds = time.perf_counter() - start
    return report
