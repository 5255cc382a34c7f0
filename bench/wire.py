"""Item 3, close to the wire: the simulator paces its line at 115200 baud; how close do we get?

Against ``python -m robostar.sim --baud 115200`` (every byte takes its wire time both ways,
no turnaround delay), the blocking client uploads a JOB file with FB, downloads it with FA,
polls AA, and reads a public parameter whose answer is one whole 250-byte packet (KE; the
simulator's state holds a text that fills the packet). The floor is the wire time of the bytes
that crossed, counted at the transport: the protocol is strictly one-way-at-a-time (request,
answer, ACK), so no two bytes share the wire and the floor is their sum times one byte time.

The breakdown of what is over the floor: "host turnaround" is the time the line waited on the
client, as a fraction of the floor: from the end of what it read (or of the wire time of what
it wrote) to its next write (decoding, deciding, ACKing, sending the next packet); "line" is
the rest (the simulator's serving loop and pacing, the loopback hops or the pseudo-terminal,
and the client's waking to read). In each round a raw host (:mod:`bench.rawline`) runs the
same transfers right after the client, on a simulator of its own started the same way: what
it adds over the floor is the line's share, which no client can remove.

Both lines the simulator serves are measured: TCP on loopback (a serial device server's
line) and a pseudo-terminal (a serial port's).
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench.counting import CountingTransport
from bench.hops import one_way_seconds
from bench.measure import BAUD, Row, median, wire_seconds
from bench.procs import ServerProcess, sim_command
from bench.rawline import RawHost, download_request, parameter_request, upload_packets
from bench.workload import JOB_NAME, job_lines
from robostar import Client
from robostar.commands.files import DownloadFile, UploadFile
from robostar.commands.system import MAX_TEXT
from robostar.sim import SimConfig
from robostar.sim.model import Model
from robostar.sim.store import STATE_FILE
from robostar.transport import transport_for_url

__all__ = ["run"]

TARGET = 0.05
"""At most this much over the wire-time floor."""
JOB_NUMBER = 7
LONG_PARAMETER = 1
"""The public parameter group whose text fills one answer packet (250 bytes with its frame)."""
LONG_TEXT = ("ROBOSTAR N1 LONG PARAMETER TEXT " * 8)[:MAX_TEXT]
LINES = ("tcp", "pty")
"""The simulator's two kinds of line."""


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


def _state_with_long_parameter(root: Path) -> Path:
    """A state directory whose public parameter :data:`LONG_PARAMETER` fills a packet."""
    snapshot = Model(SimConfig()).snapshot()
    snapshot["parameters"][str(LONG_PARAMETER)] = LONG_TEXT
    root.mkdir()
    (root / STATE_FILE).write_text(json.dumps(snapshot))
    return root


def _transfers(
    server_args: list[str], job: tuple[str, ...], polls: int, packets: int, rounds: int
) -> tuple[dict[str, list[dict[str, float]]], dict[str, list[dict[str, float]]]]:
    """Rounds of the four transfers by the client, each followed by the raw host's."""
    names = ("FB upload", "FA download", "AA polls", "250-byte packets")
    runs: dict[str, list[dict[str, float]]] = {name: [] for name in names}
    raw: dict[str, list[dict[str, float]]] = {name: [] for name in names}
    up = upload_packets(UploadFile(1, JOB_NAME, JOB_NUMBER, job))
    down = download_request(DownloadFile(1, JOB_NAME))
    long_read = parameter_request(LONG_PARAMETER)
    # Two simulators: one line serves one host at a time, and a simulator sends its answer to
    # the connection that wrote last, so two hosts on one line could see each other's answers.
    # Each keeps its state in a directory of its own (an upload is saved).
    with tempfile.TemporaryDirectory() as tmp:
        states = [_state_with_long_parameter(Path(tmp) / name) for name in ("client", "raw")]
        with (
            ServerProcess([*server_args, "--state", str(states[0])]) as sim,
            ServerProcess([*server_args, "--state", str(states[1])]) as raw_sim,
        ):
            transport = CountingTransport(transport_for_url(sim.lines[0]))
            host = RawHost(raw_sim.lines[0])
            with Client(transport, timeout=5.0) as client:
                client.status()
                if client.parameters(None, LONG_PARAMETER) != (LONG_TEXT,):
                    raise RuntimeError("KE: the long parameter did not come back whole")

                def upload() -> None:
                    client.upload_job(1, JOB_NAME, job, number=JOB_NUMBER)

                def download() -> None:
                    got = client.download_job(1, JOB_NAME)
                    if got.lines != job:
                        raise RuntimeError("FA: the job read back differs from the one uploaded")

                def poll() -> None:
                    for _ in range(polls):
                        client.status()

                def long_reads() -> None:
                    for _ in range(packets):
                        client.parameters(None, LONG_PARAMETER)

                def raw_download() -> None:
                    if host.download(down) != len(job) + 2:
                        raise RuntimeError("FA (raw): not one packet per line + size + END")

                def raw_long_reads() -> None:
                    for _ in range(packets):
                        if host.download(long_read) != 2:
                            raise RuntimeError("KE (raw): not one data packet + END")

                try:
                    for _ in range(rounds):
                        runs["FB upload"].append(_timed(transport, upload))
                        raw["FB upload"].append(_raw_timed(host, lambda: host.upload(up)))
                        runs["FA download"].append(_timed(transport, download))
                        raw["FA download"].append(_raw_timed(host, raw_download))
                        runs["AA polls"].append(_timed(transport, poll))
                        raw["AA polls"].append(_raw_timed(host, lambda: host.polls(polls)))
                        runs["250-byte packets"].append(_timed(transport, long_reads))
                        raw["250-byte packets"].append(_raw_timed(host, raw_long_reads))
                finally:
                    host.close()
    return runs, raw


def _medians(runs: dict[str, list[dict[str, float]]]) -> dict[str, dict[str, Any]]:
    return {
        name: {**{key: median(s[key] for s in samples) for key in samples[0]}, "rounds": samples}
        for name, samples in runs.items()
    }


def case_name(transfer: str, line: str) -> str:
    """The key of one transfer on one kind of line in the results (TCP's carry no suffix)."""
    return transfer if line == "tcp" else f"{transfer}, {line}"


def run(
    *,
    lines: int = 2000,
    polls: int = 1000,
    packets: int = 100,
    rounds: int = 3,
    on: tuple[str, ...] = LINES,
) -> tuple[dict[str, Any], list[Row]]:
    job = job_lines(lines)
    cases: dict[str, dict[str, Any]] = {}
    raw_cases: dict[str, dict[str, Any]] = {}
    for line in on:
        runs, raw = _transfers(
            sim_command(baud=BAUD, pty=line == "pty"), job, polls, packets, rounds
        )
        cases.update({case_name(n, line): c for n, c in _medians(runs).items()})
        raw_cases.update({case_name(n, line): c for n, c in _medians(raw).items()})
    results: dict[str, Any] = {
        "baud": BAUD,
        "lines": lines,
        "polls": polls,
        "packets": packets,
        "cases": cases,
        "raw_host": raw_cases,
    }
    rows = []
    for name, best in cases.items():
        transfer, _, line = name.partition(", ")
        size = {
            "AA polls": f"{polls} AA polls",
            "250-byte packets": f"{packets} KE reads of a 250-byte packet",
        }.get(transfer, f"{transfer} ({lines} lines)")
        raw_over = raw_cases[name]["over"]
        rows.append(
            Row(
                "3 wire",
                f"{size}, {line or 'tcp'}",
                f"{best['seconds']:.2f} s vs floor {best['floor']:.2f} s (+{best['over']:.1%}:"
                f" host turnaround {best['host']:.1%}, line {best['over'] - best['host']:.1%};"
                f" raw host {raw_over:+.1%})",
                f"≤ +{TARGET:.0%}",
                best["over"] <= TARGET,
            )
        )
    # What a message's crossing costs on each line, unpaced: on a pty the simulator starts a
    # host message's wire time one hop late (no receive stamps), and the host sees every answer
    # one hop late on both lines, so an AA exchange pays two hops on a pty and one on TCP.
    hops = {line: one_way_seconds(line) for line in on}
    results["hop_us"] = {line: hop * 1e6 for line, hop in hops.items()}
    aa_floor = {line: cases[case_name("AA polls", line)]["floor"] / polls for line in on}
    for line, hop in hops.items():
        per_exchange = 2 if line == "pty" else 1
        rows.append(
            Row(
                "3 wire",
                f"one-way hop, {line}, unpaced (reference)",
                f"{hop * 1e6:.0f} µs; {per_exchange} per AA exchange ="
                f" {per_exchange * hop / aa_floor[line]:.1%} of its floor",
            )
        )
    return results, rows
