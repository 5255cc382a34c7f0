"""Profiles behind docs/performance.md: where the time of one exchange goes, reproducibly.

``python -m bench.profiles [client|async|sim|syscalls|all]`` writes text reports to
``bench/results/profile-*.txt``:

- ``client``: cProfile (thread CPU time) of ``Client.status()`` in memory, against a peer that
  answers at once: the Python cost of every client layer above the sans-IO core;
- ``async``: the same for ``AsyncClient.status()`` over TCP against the canned server;
- ``sim``: cProfile of the simulator's serving thread (in its own process) while the client
  polls AA over TCP;
- ``syscalls``: ``strace -c`` of the blocking client and of the simulator over 1 000 AA
  exchanges (skipped where strace is missing or not permitted);
- ``instructions``: machine instructions per ``Client.status()`` in memory, counted by
  valgrind's callgrind (two runs of different lengths, the difference divided by the extra
  calls, so start-up cancels out). A count, not a time: the same on a busy machine as on a
  quiet one, so an A/B of a change to the client's path needs no quiet machine (skipped where
  valgrind is missing).
"""

from __future__ import annotations

import asyncio
import cProfile
import io
import os
import pstats
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

if __package__ in (None, ""):
    _root = Path(__file__).resolve().parent.parent
    sys.path[:0] = [str(_root), str(_root / "src")]

from bench import floor
from bench.host_cost import CannedPeer
from bench.procs import REPO, ServerProcess, sim_command
from bench.workload import STATUS
from robostar import AsyncClient, Client
from robostar.commands.status import ReadStatus
from robostar.protocol.frame import encode_packet
from robostar.transport import PeerTransport

__all__ = ["main"]

OUT = REPO / "bench" / "results"
N = 5000
_SIM_PROFILER = """
import cProfile, sys, time
from robostar.sim import server
from robostar.sim.__main__ import main
run = server.PeerHost._run
def profiled(self):
    profiler = cProfile.Profile(time.thread_time)
    profiler.enable()
    try:
        run(self)
    finally:
        profiler.disable()
        profiler.dump_stats(sys.argv[1])
server.PeerHost._run = profiled
sys.exit(main(sys.argv[2:]))
"""


def _scrub(text: str) -> str:
    """Reports go into the repository: no paths of this machine in them."""
    lines = [line for line in text.splitlines() if not line.rstrip().endswith(".pstats")]
    text = "\n".join(lines) + "\n"
    roots = {str(REPO): ".", sys.base_prefix: "<python>", sys.prefix: "<venv>"}
    for root, name in sorted(roots.items(), key=lambda item: -len(item[0])):
        text = text.replace(root, name)
    return text


def _stats(profiler: cProfile.Profile, title: str, per: int) -> str:
    out = io.StringIO()
    stats = pstats.Stats(profiler, stream=out)
    total = stats.total_tt  # type: ignore[attr-defined]
    out.write(f"{title}\n{per} exchanges; profiled thread CPU {total / per * 1e6:.0f} µs each\n")
    out.write("(cProfile inflates small calls; read the shares, not the absolute times)\n")
    stats.sort_stats("cumulative").print_stats(30)
    stats.sort_stats("tottime").print_stats(25)
    return out.getvalue()


def _profile(call: Callable[[], object], n: int) -> cProfile.Profile:
    for _ in range(n // 10):
        call()
    profiler = cProfile.Profile(time.thread_time)
    profiler.enable()
    for _ in range(n):
        call()
    profiler.disable()
    return profiler


def client() -> str:
    answer = encode_packet(ReadStatus().encode_answer(STATUS)[0])
    with Client(PeerTransport(CannedPeer(answer))) as c:
        profiler = _profile(c.status, N)
    return _stats(profiler, "Client.status() in memory (canned peer)", N)


def async_client() -> str:
    async def run(url: str) -> cProfile.Profile:
        c = AsyncClient(url)
        await c.connect()
        for _ in range(N // 10):
            await c.status()
        profiler = cProfile.Profile(time.thread_time)
        profiler.enable()
        for _ in range(N):
            await c.status()
        profiler.disable()
        await c.close()
        return profiler

    with ServerProcess([sys.executable, "-m", "bench.floor", "canned"]) as canned:
        profiler = asyncio.run(run(f"tcp://{canned.lines[0]}"))
    return _stats(profiler, "AsyncClient.status() over TCP, canned server", N)


def sim() -> str:
    with tempfile.TemporaryDirectory() as tmp:
        dump = Path(tmp) / "sim.pstats"
        args = [sys.executable, "-c", _SIM_PROFILER, str(dump), *sim_command()[3:]]
        with ServerProcess(args) as server, Client(server.lines[0]) as c:
            for _ in range(N):
                c.status()
        for _ in range(100):
            if dump.exists():
                break
            time.sleep(0.05)
        out = io.StringIO()
        stats = pstats.Stats(str(dump), stream=out)
        total = stats.total_tt  # type: ignore[attr-defined]
        out.write(
            f"simulator serving thread, {N} AA exchanges over TCP;"
            f" profiled thread CPU {total / N * 1e6:.0f} µs each\n"
        )
        stats.sort_stats("cumulative").print_stats(35)
        stats.sort_stats("tottime").print_stats(25)
        return out.getvalue()


def _strace(pid: int, action: Callable[[], object], path: Path) -> str:
    tracer = subprocess.Popen(
        ["strace", "-f", "-c", "-p", str(pid), "-o", str(path)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    time.sleep(1.0)  # strace attaches asynchronously
    action()
    tracer.terminate()
    tracer.wait(10)
    return path.read_text() if path.exists() else "(strace wrote nothing)\n"


def syscalls() -> str:
    if shutil.which("strace") is None:
        return "strace not found: skipped\n"
    n = 1000
    report = []
    with (
        tempfile.TemporaryDirectory() as tmp,
        ServerProcess(sim_command()) as server,
        Client(server.lines[0]) as c,
    ):

        def poll() -> None:
            for _ in range(n):
                c.status()

        poll()
        report.append(f"client (this process), {n} AA exchanges:\n")
        report.append(_strace(os.getpid(), poll, Path(tmp) / "client.txt"))
        report.append(f"\nsimulator process, {n} AA exchanges:\n")
        report.append(_strace(server.pid, poll, Path(tmp) / "sim.txt"))
    with (
        tempfile.TemporaryDirectory() as tmp,
        ServerProcess([sys.executable, "-m", "bench.floor"]) as floor_server,
    ):
        sock = floor.connect(floor_server.lines[0])
        report.append(f"\nraw floor client, {n} exchanges:\n")
        report.append(
            _strace(
                os.getpid(),
                lambda: floor.client_loop(sock, seconds=60, limit=n),
                Path(tmp) / "floor.txt",
            )
        )
        sock.close()
    return "".join(report)


_STATUS_CALLS = """
import gc
import sys
from bench.host_cost import CannedPeer
from bench.workload import STATUS
from robostar import Client
from robostar.commands.status import ReadStatus
from robostar.protocol.frame import encode_packet
from robostar.transport import PeerTransport
answer = encode_packet(ReadStatus().encode_answer(STATUS)[0])
with Client(PeerTransport(CannedPeer(answer))) as c:
    c.status()
    # start-up's objects out of the collector's way: a full collection would otherwise walk
    # every module imported, so the count per call would follow the size of the import graph
    # (and which .pyc files had to be compiled) rather than the call's path
    gc.collect()
    gc.freeze()
    for _ in range(int(sys.argv[1])):
        c.status()
"""


def callgrind_count(script: str, *args: str) -> int:
    """Instructions callgrind counts for ``python -c script args...`` run from the repository
    (the same hash seed every run, so the dictionaries' layout is the same)."""
    done = subprocess.run(
        [
            "valgrind",
            "--tool=callgrind",
            "--callgrind-out-file=/dev/null",
            sys.executable,
            "-c",
            script,
            *args,
        ],
        cwd=REPO,
        env={
            **os.environ,
            "PYTHONPATH": os.pathsep.join((str(REPO), str(REPO / "src"))),
            "PYTHONHASHSEED": "0",
        },
        capture_output=True,
        text=True,
        check=True,
    )
    for line in done.stderr.splitlines():
        if "Collected :" in line:
            return int(line.rsplit(":", 1)[1])
    raise RuntimeError(f"callgrind gave no count:\n{done.stderr[-2000:]}")


def _instructions_run(calls: int) -> int:
    """Instructions callgrind counts for a process making ``calls`` in-memory status reads."""
    return callgrind_count(_STATUS_CALLS, str(calls))


def instructions() -> str:
    if shutil.which("valgrind") is None:
        return "valgrind not found: skipped\n"
    short, long = 2_000, 12_000
    per_call = (_instructions_run(long) - _instructions_run(short)) / (long - short)
    return (
        "Client.status() in memory (canned peer), counted by callgrind\n"
        f"{per_call:,.0f} instructions per call"
        f" ({long:,} calls less {short:,}, start-up cancelled out)\n"
    )


PROFILES: dict[str, Callable[[], str]] = {
    "client": client,
    "async": async_client,
    "sim": sim,
    "syscalls": syscalls,
    "instructions": instructions,
}


def main(argv: list[str] | None = None) -> int:
    names = (argv if argv is not None else sys.argv[1:]) or ["all"]
    chosen = list(PROFILES) if names == ["all"] else names
    for name in chosen:
        if name not in PROFILES:
            raise SystemExit(f"profile: {name!r} is not one of {', '.join(PROFILES)} or all")
    OUT.mkdir(parents=True, exist_ok=True)
    for name in chosen:
        path = OUT / f"profile-{name}.txt"
        path.write_text(_scrub(PROFILES[name]()))
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
