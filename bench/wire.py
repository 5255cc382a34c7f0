"""Item 3, close to the wire: the simulator paces its line at 115200 baud; how close do we get?

Against ``python -m robostar.sim --baud 115200`` (every byte takes its wire time both ways,
no turnaround delay), the blocking client uploads a JOB file with FB, downloads it with FA, and
polls AA. The floor is the wire time of the bytes that crossed, counted at the transport: the
protocol is strictly one-way-at-a-time (request, answer, ACK), so no two bytes share the wire
and the floor is their sum times one byte time. "host" is the client's own share, as a
fraction of the floor: the time it spends between reads (decoding, ACKing, sending the next
packet); the rest of the excess is the simulator's serving loop and the loopback hops.

In each round a raw-socket host (:mod:`bench.rawline`) runs the same three transfers right
after the client, on a simulator of its own started the same way: what it adds over the floor
is the simulator's and the loopback's share, which no client can remove.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from bench.counting import CountingTransport
from bench.measure import BAUD, Row, median, wire_seconds
from bench.procs import ServerProcess, sim_command
from bench.rawline import RawHost, download_request, upload_packets
from bench.workload import JOB_NAME, job_lines
from robostar import Client
from robostar.commands.files import DownloadFile, UploadFile
from robostar.transport import transport_for_url

__all__ = ["run"]

TARGET = 0.05
"""At most this much over the wire-time floor."""
JOB_NUMBER = 7


def _timed(transport: CountingTransport, action: Callable[[], object]) -> dict[str, float]:
    before = transport.total
    transport.restart_busy()
    cpu = time.process_time()
    wall = time.perf_counter()
    action()
    wall = time.perf_counter() - wall
    cpu = time.process_time() - cpu
    nbytes = transport.total - before
    floor = wire_seconds(nbytes)
    return {
        "seconds": wall,
        "bytes": nbytes,
        "floor": floor,
        "over": wall / floor - 1,
        "host": transport.host_busy / floor,
        "cpu": cpu,
    }


def _raw_timed(host: RawHost, action: Callable[[], object]) -> dict[str, float]:
    before = host.moved
    wall = time.perf_counter()
    action()
    wall = time.perf_counter() - wall
    floor = wire_seconds(host.moved - before)
    return {"seconds": wall, "bytes": host.moved - before, "floor": floor, "over": wall / floor - 1}


def _transfers(
    server_args: list[str], job: tuple[str, ...], polls: int, rounds: int
) -> tuple[dict[str, list[dict[str, float]]], dict[str, list[dict[str, float]]]]:
    """Rounds of the three transfers by the client, each followed by the raw host's."""
    runs: dict[str, list[dict[str, float]]] = {"FB upload": [], "FA download": [], "AA polls": []}
    raw: dict[str, list[dict[str, float]]] = {name: [] for name in runs}
    up = upload_packets(UploadFile(1, JOB_NAME, JOB_NUMBER, job))
    down = download_request(DownloadFile(1, JOB_NAME))
    # Two simulators: one line serves one host at a time, and a simulator sends its answer to
    # the connection that wrote last, so two hosts on one line could see each other's answers.
    with ServerProcess(server_args) as sim, ServerProcess(server_args) as raw_sim:
        transport = CountingTransport(transport_for_url(sim.lines[0]))
        host = RawHost(raw_sim.lines[0])
        with Client(transport, timeout=5.0) as client:
            client.status()

            def upload() -> None:
                client.upload_job(1, JOB_NAME, job, number=JOB_NUMBER)

            def download() -> None:
                got = client.download_job(1, JOB_NAME)
                if got.lines != job:
                    raise RuntimeError("FA: the job read back differs from the one uploaded")

            def poll() -> None:
                for _ in range(polls):
                    client.status()

            def raw_download() -> None:
                if host.download(down) != len(job) + 2:
                    raise RuntimeError("FA (raw): not one packet per line + size + END")

            try:
                for _ in range(rounds):
                    runs["FB upload"].append(_timed(transport, upload))
                    raw["FB upload"].append(_raw_timed(host, lambda: host.upload(up)))
                    runs["FA download"].append(_timed(transport, download))
                    raw["FA download"].append(_raw_timed(host, raw_download))
                    runs["AA polls"].append(_timed(transport, poll))
                    raw["AA polls"].append(_raw_timed(host, lambda: host.polls(polls)))
            finally:
                host.close()
    return runs, raw


def _medians(runs: dict[str, list[dict[str, float]]]) -> dict[str, dict[str, Any]]:
    return {
        name: {**{key: median(s[key] for s in samples) for key in samples[0]}, "rounds": samples}
        for name, samples in runs.items()
    }


def run(
    *, lines: int = 2000, polls: int = 1000, rounds: int = 3
) -> tuple[dict[str, Any], list[Row]]:
    job = job_lines(lines)
    runs, raw = _transfers(sim_command(baud=BAUD), job, polls, rounds)
    cases = _medians(runs)
    raw_cases = _medians(raw)
    results: dict[str, Any] = {
        "baud": BAUD,
        "lines": lines,
        "polls": polls,
        "cases": cases,
        "raw_host": raw_cases,
    }
    rows = []
    for name, best in cases.items():
        label = f"{name} ({lines} lines)" if name != "AA polls" else f"{polls} AA polls"
        rows.append(
            Row(
                "3 wire",
                label,
                f"{best['seconds']:.2f} s vs floor {best['floor']:.2f} s (+{best['over']:.1%};"
                f" host CPU {best['cpu'] / best['floor']:.1%})",
                f"≤ +{TARGET:.0%}",
                best["over"] <= TARGET,
            )
        )
    for name, best in raw_cases.items():
        rows.append(
            Row("3 wire", f"{name}, raw-socket host", f"+{best['over']:.1%} over its floor")
        )
    return results, rows
