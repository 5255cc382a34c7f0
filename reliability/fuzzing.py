"""The long-run fuzzer: seeded random and mutated inputs for every target, with figures.

Each input goes to one target of :mod:`reliability.targets` (round robin), built from a seeded
generator, so a run is repeatable from its seed and a violation is reported with the input
that caused it. Inputs are arbitrary bytes, arbitrary splits, and valid packets mutated (bits
flipped, bytes dropped, inserted, doubled; packets lost, doubled, swapped).
"""

from __future__ import annotations

import random
import re
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from reliability.samples import SAMPLES
from reliability.simfuzz import check_sim_request
from reliability.targets import (
    KnownIssue,
    Violation,
    check_answer,
    check_controller_link,
    check_frames,
    check_host_link,
    check_request,
    check_resync,
    split,
)
from robostar.protocol.frame import ACK, ETX, NAK, RST, STX, encode_packet

__all__ = ["TARGETS", "FuzzReport", "Inputs", "run_fuzz"]

_SPECIAL = (STX, ETX, ACK, NAK, RST, 0xFF, 0x30, 0x34, 0x20)
_REQUESTS = tuple(s.command.encode() for s in SAMPLES)
_ANSWERS = tuple(a for s in SAMPLES for a in s.answer)
_FRAMES = tuple(encode_packet(d) for d in _REQUESTS + _ANSWERS)


class Inputs:
    """Random inputs from one seed."""

    def __init__(self, seed: int) -> None:
        self.rng = random.Random(seed)

    def byte(self) -> int:
        rng = self.rng
        return rng.choice(_SPECIAL) if rng.random() < 0.3 else rng.randrange(256)

    def noise(self, most: int = 64) -> bytes:
        return bytes(self.byte() for _ in range(self.rng.randrange(most + 1)))

    def mutate(self, data: bytes, most: int = 4) -> bytes:
        rng = self.rng
        out = bytearray(data)
        for _ in range(rng.randrange(1, most + 1)):
            at = rng.randrange(len(out) + 1)
            op = rng.randrange(5)
            if op == 0 and at < len(out):
                out[at] ^= rng.randrange(1, 256)
            elif op == 1 and at < len(out):
                del out[at]
            elif op == 2:
                out.insert(at, self.byte())
            elif op == 3 and at < len(out):
                out.insert(at, out[at])
            else:
                del out[at:]
        return bytes(out)

    def cuts(self, length: int) -> list[int]:
        return [self.rng.randrange(length + 1) for _ in range(self.rng.randrange(6))]

    def stream(self) -> bytes:
        """Valid frames and control bytes, then mutated; a fifth of the time noise, and now
        and then a frame near or over the length limit."""
        rng = self.rng
        roll = rng.random()
        if roll < 0.05:
            # A frame near or over the 250-byte limit, with more line after it.
            body = bytes(rng.randrange(0x20, 0x7F) for _ in range(rng.randrange(240, 600)))
            return self.mutate(b"\x02" + body + rng.choice(_FRAMES), 2)
        if roll < 0.25:
            return self.noise(300)
        parts = [rng.choice(_FRAMES) for _ in range(rng.randrange(1, 5))]
        return self.mutate(b"".join(parts), 6)

    def packets(self, answer: list[bytes]) -> list[bytes]:
        rng = self.rng
        out = list(answer)
        for _ in range(rng.randrange(1, 4)):
            op = rng.randrange(5)
            at = rng.randrange(max(len(out), 1))
            if op == 0 and out:
                out[at] = self.mutate(out[at])
            elif op == 1 and out:
                del out[at]
            elif op == 2 and out:
                out.insert(at, out[at])
            elif op == 3 and len(out) > 1:
                j = rng.randrange(len(out))
                out[at], out[j] = out[j], out[at]
            else:
                out.insert(at, rng.choice(_ANSWERS))
        return out

    def chunks(self) -> list[bytes]:
        stream = self.stream()
        return split(stream, self.cuts(len(stream)))


# -- one input per target ----------------------------------------------------------------------
def _frames(src: Inputs) -> tuple[str, Any]:
    stream = src.stream()
    cuts = src.cuts(len(stream))
    check_frames(stream, cuts)
    return "ok", (stream, cuts)


def _resync(src: Inputs) -> tuple[str, Any]:
    noise, first, second = src.stream(), src.rng.choice(_FRAMES), src.rng.choice(_FRAMES)
    check_resync(noise, first, second, src.cuts(len(noise)))
    return "ok", (noise, first, second)


def _answers(src: Inputs) -> tuple[str, Any]:
    case = src.rng.choice(SAMPLES)
    packets = (
        src.packets(case.answer)
        if src.rng.random() < 0.8
        else [src.noise(80) for _ in range(src.rng.randrange(4))]
    )
    return check_answer(case.command, packets), (case.command, packets)


def _requests(src: Inputs) -> tuple[str, Any]:
    rng = src.rng
    roll = rng.random()
    if roll < 0.6:
        data = src.mutate(rng.choice(_REQUESTS))
    elif roll < 0.8:
        data = rng.choice(_REQUESTS)[:3] + src.noise(60)
    else:
        data = src.noise(80)
    return check_request(data), data


def _host_link(src: Inputs) -> tuple[str, Any]:
    case = src.rng.choice(SAMPLES)
    chunks = src.chunks()
    state = check_host_link(case.command.encode(), case.command, chunks)
    return state.value, (case.command, chunks)


def _controller_link(src: Inputs) -> tuple[str, Any]:
    case = src.rng.choice(SAMPLES)
    chunks = src.chunks()
    return check_controller_link(chunks, case.answer[:1]).value, chunks


def _sim(src: Inputs) -> tuple[str, Any]:
    rng = src.rng
    data = src.mutate(rng.choice(_REQUESTS)) if rng.random() < 0.8 else src.noise(80)
    return check_sim_request(data), data


TARGETS: dict[str, Callable[[Inputs], tuple[str, Any]]] = {
    "frame decoder": _frames,
    "frame resync": _resync,
    "answer decoders": _answers,
    "request decoder": _requests,
    "host link": _host_link,
    "controller link": _controller_link,
    "simulator requests": _sim,
}
"""Target name -> one fuzz step (returns an outcome label and the input, for the report)."""


@dataclass
class FuzzReport:
    """Figures of a fuzz run."""

    seed: int
    inputs: int = 0
    seconds: float = 0.0
    per_target: Counter[str] = field(default_factory=Counter)
    outcomes: dict[str, Counter[str]] = field(default_factory=dict)
    violations: list[dict[str, str]] = field(default_factory=list)
    known: Counter[str] = field(default_factory=Counter)

    def as_json(self) -> dict[str, Any]:
        return {
            "seed": self.seed,
            "inputs": self.inputs,
            "seconds": round(self.seconds, 1),
            "inputs_per_second": round(self.inputs / self.seconds) if self.seconds else None,
            "violations": len(self.violations),
            "known_issue_hits": dict(self.known),
            "violation_kinds": dict(Counter(_signature(v) for v in self.violations)),
            "per_target": dict(self.per_target),
            "outcomes": {name: dict(c.most_common()) for name, c in self.outcomes.items()},
            "violation_samples": self.violations[:20],
        }


_BYTES = re.compile(r"b'(?:[^'\\]|\\.)*'|b\"(?:[^\"\\]|\\.)*\"")


def _signature(violation: dict[str, str]) -> str:
    """A violation without its input bytes, so that one bug counts as one kind."""
    return f"{violation['target']}: {_BYTES.sub('<bytes>', violation['error'])[:160]}"


def run_fuzz(
    inputs: int,
    seed: int = 0,
    targets: list[str] | None = None,
    progress: Callable[[int], None] | None = None,
) -> FuzzReport:
    """Run ``inputs`` inputs over the targets round robin; violations are collected, not raised,
    and hits of known issues counted apart."""
    names = targets or list(TARGETS)
    src = Inputs(seed)
    report = FuzzReport(seed)
    report.outcomes = {name: Counter() for name in names}
    start = time.perf_counter()
    for i in range(inputs):
        name = names[i % len(names)]
        try:
            outcome, _ = TARGETS[name](src)
        except KnownIssue as exc:
            outcome = "known issue"
            report.known[exc.key] += 1
        except Violation as exc:
            outcome = "VIOLATION"
            report.violations.append({"target": name, "index": str(i), "error": str(exc)[:2000]})
        report.per_target[name] += 1
        report.outcomes[name][outcome] += 1
        if progress is not None and (i + 1) % 10_000 == 0:
            progress(i + 1)
    report.inputs = inputs
    report.seconds = time.perf_counter() - start
    return report
