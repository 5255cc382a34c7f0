"""Item 1, host cost per exchange: CPU time of one whole exchange in memory, no I/O.

The host side of an exchange runs as the client runs it: build the command, encode the
request, start the exchange on a :class:`~robostar.protocol.link.HostLink`, take the bytes to
write, feed the controller's answer frame(s), take the ACK, decode the answer into its typed
result. The controller's answer frames are made once beforehand (the controller's cost is not
the host's). Each figure is thread CPU time, the median of several rounds.

"FA line packet" is the marginal cost of one more line packet in a download: the slope of the
cost of FA downloads of three lengths against their line count.

For context, ``client_in_memory`` runs the whole blocking :class:`~robostar.Client` (lock,
plan, retries policy, exchange driver, transport calls) against an in-process peer that
answers at once, so the cost above the sans-IO core shows.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from bench.measure import BAUD, Row, median, wire_seconds
from bench.workload import POINT, POSITION, STATUS, job_lines
from robostar.client import Client
from robostar.commands.base import Command
from robostar.commands.files import DownloadFile
from robostar.commands.status import ReadPosition, ReadStatus
from robostar.commands.variables import ReadGlobalPoint
from robostar.protocol.frame import STX, encode_packet
from robostar.protocol.link import AnswerReceived, HostLink
from robostar.transport import PeerTransport
from robostar.types import JobFile, PositionKind

__all__ = ["CannedPeer", "run"]

AA_TARGET_US = 20.0
WIRE_SHARE = 0.05
"""Host CPU may take at most this share of the exchange's wire time at 115200 baud."""


@dataclass(frozen=True)
class _Case:
    name: str
    make: Callable[[], Command[Any]]
    result: object

    def frames(self) -> list[bytes]:
        return [encode_packet(p) for p in self.make().encode_answer(self.result)]

    def wire_bytes(self) -> int:
        """Request + answer packets + one ACK per answer packet."""
        frames = self.frames()
        return len(encode_packet(self.make().encode())) + sum(map(len, frames)) + len(frames)


def _cases(fa_lines: int) -> list[_Case]:
    job = JobFile(job_lines(fa_lines))
    return [
        _Case("AA", ReadStatus, STATUS),
        _Case("AC (4 axes)", lambda: ReadPosition(1, PositionKind.XY), POSITION),
        _Case("GR point (6 axes)", lambda: ReadGlobalPoint(1, 5), POINT),
        _Case(f"FA {fa_lines} lines", lambda: DownloadFile(1, "BENCH.JOB"), job),
    ]


def exchange_loop(make: Callable[[], Command[Any]], frames: Sequence[bytes], n: int) -> int:
    """Run ``n`` host-side exchanges; returns thread CPU nanoseconds."""
    link = HostLink()
    now = 0.0
    start = time.thread_time_ns()
    for _ in range(n):
        command = make()
        link.send_request(command.encode(), command.SHAPE, now)
        link.data_to_send()
        packets = []
        for frame in frames:
            for event in link.receive_data(frame, now):
                if isinstance(event, AnswerReceived):
                    packets.append(event.data)
            link.data_to_send()
        command.decode_answer(packets)
    spent = time.thread_time_ns() - start
    if not link.idle:
        raise RuntimeError(f"exchange did not complete: link in {link.state}")
    return spent


def _interleaved_us(cases: Sequence[tuple[_Case, int]], rounds: int) -> list[float]:
    """Median CPU µs per exchange of each (case, exchanges per round), the cases taking turns
    round after round so that a noisy neighbour weighs on all of them alike."""
    prepared = [(case.make, case.frames(), n) for case, n in cases]
    for make, frames, n in prepared:
        exchange_loop(make, frames, max(n // 10, 1))  # warm-up
    spent: list[list[float]] = [[] for _ in prepared]
    for _ in range(rounds):
        for i, (make, frames, n) in enumerate(prepared):
            spent[i].append(exchange_loop(make, frames, n) / n / 1000)
    return [median(values) for values in spent]


class CannedPeer:
    """A byte peer that answers every request at once with the same framed answer."""

    def __init__(self, answer: bytes) -> None:
        self.answer = answer
        self._out = bytearray()

    def feed(self, data: bytes, now: float) -> None:
        if data[:1] == bytes((STX,)):
            self._out += self.answer

    def output(self, now: float) -> bytes:
        out = bytes(self._out)
        self._out.clear()
        return out

    def next_deadline(self) -> float | None:
        return None


def _client_in_memory_us(n: int, rounds: int) -> float:
    answer = encode_packet(ReadStatus().encode_answer(STATUS)[0])
    with Client(PeerTransport(CannedPeer(answer))) as client:
        for _ in range(max(n // 10, 1)):
            client.status()
        spent = []
        for _ in range(rounds):
            start = time.thread_time_ns()
            for _ in range(n):
                client.status()
            spent.append((time.thread_time_ns() - start) / n / 1000)
    return median(spent)


def _slope(xs: Sequence[float], ys: Sequence[float]) -> float:
    """Least-squares slope of ``ys`` against ``xs``."""
    mx = sum(xs) / len(xs)
    my = sum(ys) / len(ys)
    num = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True))
    return num / sum((x - mx) ** 2 for x in xs)


def run(
    *, n: int = 2000, rounds: int = 15, fa_lines: int = 200
) -> tuple[dict[str, Any], list[Row]]:
    """``n`` exchanges per case and round (FA downloads: enough for as many packets)."""
    results: dict[str, Any] = {"n": n, "rounds": rounds, "baud": BAUD, "cases": {}}
    rows = []
    singles = _cases(fa_lines)[:3]
    # FA: the marginal cost of one line packet, the slope of download cost against length.
    sizes = (fa_lines // 2, fa_lines, 2 * fa_lines)
    fa = [_cases(k)[3] for k in sizes]
    fa_n = max(n // fa_lines, 2)
    cost = _interleaved_us([*((c, n) for c in singles), *((c, fa_n) for c in fa)], rounds)
    for case, us in zip(singles, cost, strict=False):
        wire = wire_seconds(case.wire_bytes()) * 1e6
        limit = WIRE_SHARE * wire
        if case.name == "AA":
            limit = min(limit, AA_TARGET_US)
        results["cases"][case.name] = {
            "cpu_us": us,
            "wire_bytes": case.wire_bytes(),
            "wire_us": wire,
            "share": us / wire,
            "limit_us": limit,
        }
        rows.append(
            Row(
                "1 host cost",
                case.name,
                f"{us:.1f} µs ({us / wire:.1%} of {wire / 1000:.2f} ms wire)",
                f"≤ {limit:.0f} µs",
                us <= limit,
            )
        )
    fa_cost = cost[len(singles) :]
    per_line = _slope(sizes, fa_cost)
    line_bytes = _slope(sizes, [case.wire_bytes() for case in fa])
    wire = wire_seconds(1) * line_bytes * 1e6
    results["cases"]["FA line packet"] = {
        "cpu_us": per_line,
        "wire_bytes": line_bytes,
        "wire_us": wire,
        "share": per_line / wire,
        "limit_us": WIRE_SHARE * wire,
        "download_us": {f"{k} lines": t for k, t in zip(sizes, fa_cost, strict=True)},
    }
    rows.append(
        Row(
            "1 host cost",
            "FA line packet",
            f"{per_line:.1f} µs ({per_line / wire:.1%} of {wire / 1000:.2f} ms wire)",
            f"≤ {WIRE_SHARE * wire:.0f} µs",
            per_line <= WIRE_SHARE * wire,
        )
    )
    client_us = _client_in_memory_us(n, rounds)
    results["client_in_memory_aa_us"] = client_us
    rows.append(Row("1 host cost", "AA, whole sync Client in memory", f"{client_us:.1f} µs"))
    return results, rows
