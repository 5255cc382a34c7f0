"""The history checker's judge: a recorded history of operations against the simulator's journal.

Each :class:`Op` is one consumer's operation: when it was invoked and when its answer came
(``time.monotonic()``, the clock the simulator's journal uses when both run in one process),
what it asked (its command as the journal writes commands), and what came back: a value, a
refusal, or an unknown outcome. :func:`judge` checks three rules:

1. **reads**: every read's value equals the controller's state at some instant between the
   read's invocation and its response (a position on a path: at some instant of that window);
2. **writes**: a state change told success was carried out exactly once, within its window; a
   refused one zero times; one of unknown outcome zero or one time (the journal says which);
   nothing was carried out that no operation asked for;
3. **order**: each consumer's changes took effect in the order it sent them.

Everything here is pure: the journal's entries and the ops in, :class:`Violation` objects out.
"""

from __future__ import annotations

import bisect
import itertools
import json
import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from robostar.sim.journal import path_at

__all__ = ["Op", "Timeline", "Verdict", "Violation", "judge"]

POSITION_TOLERANCE = 0.0015
"""AC's answers carry three decimals."""
FLOAT_TOLERANCE = 0.0015

OK, REFUSED, UNKNOWN, FAILED = "ok", "refused", "unknown", "failed"
"""An op's outcome: answered, refused by the controller or the server, outcome unknown (a
timeout, a lost line), or a read that got no value (not judged)."""


@dataclass
class Op:
    """One operation of one consumer."""

    consumer: str
    seq: int
    code: str
    args: dict[str, Any]
    """The command's fields as the journal writes them (robostar.sim.journal.jsonable)."""
    write: bool
    inv: float
    resp: float = math.inf
    outcome: str = UNKNOWN
    value: Any = None
    """A read's value, normalised (see reliability.history_ops.normalise)."""
    error: str = ""

    def describe(self) -> str:
        what = json.dumps(self.args, separators=(",", ":"))
        got = self.error if self.outcome != OK else json.dumps(self.value)
        return (
            f"{self.consumer}#{self.seq} {self.code} {what} [{self.inv:.4f}, {self.resp:.4f}]"
            f" {self.outcome}: {got}"
        )


@dataclass
class Violation:
    rule: str
    message: str
    ops: list[Op]
    around: list[dict[str, Any]] = field(default_factory=list)

    def render(self) -> str:
        lines = [f"VIOLATION ({self.rule}): {self.message}"]
        lines += [f"  op: {op.describe()}" for op in self.ops]
        lines += ["  journal:"] + [
            "    " + json.dumps(entry, separators=(",", ":"))[:400] for entry in self.around
        ]
        return "\n".join(lines)


@dataclass
class Verdict:
    reads: int = 0
    writes: int = 0
    unchecked: int = 0
    """Reads with no value (an error), or of a jogging channel's position."""
    violations: list[Violation] = field(default_factory=list)

    @property
    def checked(self) -> int:
        return self.reads + self.writes


class Timeline:
    """The journal's states over time: the state in force at any instant."""

    def __init__(self, entries: Iterable[dict[str, Any]]):
        self.entries = sorted(entries, key=lambda e: e["t"])
        self.times: list[float] = []
        self.states: list[dict[str, Any]] = []
        state: dict[str, Any] = {}
        for entry in self.entries:
            state = dict(entry["state"]) if entry["ev"] == "start" else {**state, **entry["set"]}
            self.times.append(entry["t"])
            self.states.append(state)

    def during(self, lo: float, hi: float) -> list[tuple[float, float, dict[str, Any]]]:
        """Each state in force at some instant of [lo, hi], with the part of [lo, hi] it held."""
        first = max(0, bisect.bisect_right(self.times, lo) - 1)
        out = []
        for i in range(first, len(self.times)):
            start = self.times[i]
            if start > hi:
                break
            end = self.times[i + 1] if i + 1 < len(self.times) else math.inf
            out.append((max(lo, start), min(hi, end), self.states[i]))
        return out

    def around(self, lo: float, hi: float, extra: int = 3) -> list[dict[str, Any]]:
        a = max(0, bisect.bisect_left(self.times, lo) - extra)
        b = min(len(self.times), bisect.bisect_right(self.times, hi) + extra)
        return self.entries[a:b]


# -- reads -------------------------------------------------------------------------------------
def _close(a: Sequence[float], b: Sequence[float], tol: float) -> bool:
    return len(a) == len(b) and all(abs(x - y) <= tol for x, y in zip(a, b, strict=True))


def _on_path(path: dict[str, Any], lo: float, hi: float, value: Sequence[float]) -> bool:
    """Is ``value`` the path's position at some instant of [lo, hi]?"""
    points = path["knots"] or [path["start"], path["end"]]
    t0, duration = path["t0"], path["duration"]
    spans = len(points) - 1
    # Before it started and after it ended the position is constant.
    if lo <= t0 and _close(points[0], value, POSITION_TOLERANCE):
        return True
    if hi >= t0 + duration and _close(points[-1], value, POSITION_TOLERANCE):
        return True
    if duration <= 0:
        return False
    for i in range(spans):
        ta, tb = t0 + duration * i / spans, t0 + duration * (i + 1) / spans
        a, b = max(lo, ta), min(hi, tb)
        if a > b:
            continue
        # Each axis is straight in time on this span: where is it within tolerance?
        low, high = a, b
        for axis, target in enumerate(value):
            pa, pb = points[i][axis], points[i + 1][axis]
            slope = (pb - pa) / (tb - ta)
            if abs(slope) < 1e-12:
                if abs(pa - target) > POSITION_TOLERANCE:
                    low, high = 1.0, 0.0
                    break
                continue
            u = ta + (target - POSITION_TOLERANCE - pa) / slope
            v = ta + (target + POSITION_TOLERANCE - pa) / slope
            low, high = max(low, min(u, v)), min(high, max(u, v))
            if low > high:
                break
        if low <= high + 1e-9:
            return True
    return False


def _position_matches(state: dict[str, Any], lo: float, hi: float, op: Op) -> bool | None:
    channel = op.args["channel"]
    if state.get(f"ch{channel}.jog"):
        return None
    path = state.get(f"ch{channel}.path")
    if path is not None:
        return _on_path(path, lo, hi, op.value)
    joints = state.get(f"ch{channel}.joints")
    return joints is not None and _close(joints, op.value, POSITION_TOLERANCE)


def expected(state: dict[str, Any], op: Op) -> Any:
    """What a read other than AC answers in ``state``."""
    args = op.args
    code = op.code
    if code == "AA":
        return state["status"]
    if code == "AB":
        return [code for code, _ in state["alarms"]]
    if code == "CA":
        return state[f"ch{args['channel']}.speed"]
    if code == "ED":
        return state[f"ch{args['channel']}.step"]
    if code == "GA":
        return state["in"][args["port"]]
    if code == "GB":
        return state["out"][args["port"]]
    if code == "GR" and "value" not in args:
        if "channel" in args:
            return state.get(f"point.{args['channel']}.{args['index']}")
        key = f"{op.args.get('kind', 'int')}.{args['index']}"
        return state.get(key, 0)
    if code == "FA":
        return state.get(f"file.{args['channel']}.{args['file']}")
    raise ValueError(f"no rule for reading {code}")


def _read_matches(state: dict[str, Any], lo: float, hi: float, op: Op) -> bool | None:
    if op.code == "AC":
        return _position_matches(state, lo, hi, op)
    want = expected(state, op)
    if op.code == "AB" and op.value != want:
        # Two identical alarm packets in a row (one code on two channels: AB carries no
        # channel) may be one packet and its resend to the host's link, which keeps one then.
        return op.value == [c for i, c in enumerate(want) if i == 0 or want[i - 1] != c]
    if isinstance(want, float) or isinstance(op.value, float):
        return want is not None and op.value is not None and abs(want - op.value) <= FLOAT_TOLERANCE
    return bool(want == op.value)


def _judge_read(timeline: Timeline, op: Op, verdict: Verdict) -> None:
    if op.outcome != OK:
        verdict.unchecked += 1
        return
    windows = timeline.during(op.inv, op.resp)
    results = [_read_matches(state, lo, hi, op) for lo, hi, state in windows]
    if any(r is None for r in results):
        verdict.unchecked += 1
        return
    verdict.reads += 1
    if not any(results):
        seen = [expected(s, op) if op.code != "AC" else _where(s, op) for _, _, s in windows]
        verdict.violations.append(
            Violation(
                "read",
                f"{op.code} answered {json.dumps(op.value)}; the controller held "
                f"{json.dumps(seen)} between invocation and response",
                [op],
                timeline.around(op.inv, op.resp),
            )
        )


def _where(state: dict[str, Any], op: Op) -> Any:
    channel = op.args["channel"]
    path = state.get(f"ch{channel}.path")
    if path is not None:
        return {"path": [path["start"], path["end"]], "t0": path["t0"], "at_t0": path_at(path, 0)}
    return state.get(f"ch{channel}.joints")


# -- writes ------------------------------------------------------------------------------------
def _key(code: str, args: dict[str, Any]) -> str:
    return code + json.dumps(args, sort_keys=True, separators=(",", ":"))


def _judge_writes(
    timeline: Timeline,
    ops: Sequence[Op],
    codes: set[str],
    since: float,
    verdict: Verdict,
    sure: set[int],
) -> dict[int, float]:
    """Match the journal's carried-out commands to the write ops; returns op id -> time.
    ``sure`` gets the ops whose entry no other op could have sent."""
    done = [
        e
        for e in timeline.entries
        if e["ev"] == "cmd" and e["result"] == "done" and e["code"] in codes and e["t"] >= since
    ]
    by_key: dict[str, list[Op]] = defaultdict(list)
    every: dict[str, list[Op]] = defaultdict(list)
    for op in sorted(ops, key=lambda op: op.inv):
        if op.write:
            every[_key(op.code, op.args)].append(op)
            if op.outcome in (OK, UNKNOWN):
                by_key[_key(op.code, op.args)].append(op)
    # Per command: the ops invoked so far (a pointer into each list by invocation) whose window
    # may still hold the journal's next entry; the entries come in time order.
    next_index: dict[str, int] = defaultdict(int)
    active: dict[str, list[Op]] = defaultdict(list)
    claimed: dict[int, float] = {}
    for entry in done:
        key, t = _key(entry["code"], entry["cmd"]), entry["t"]
        waiting = by_key.get(key, [])
        while next_index[key] < len(waiting) and waiting[next_index[key]].inv <= t:
            active[key].append(waiting[next_index[key]])
            next_index[key] += 1
        active[key] = [op for op in active[key] if op.outcome == UNKNOWN or op.resp >= t]
        candidates = active[key]
        if not candidates:
            near = [op for op in every.get(key, []) if op.inv - 1.0 <= t <= op.resp + 1.0][:6]
            verdict.violations.append(
                Violation(
                    "write",
                    f"{entry['code']} was carried out at {t:.4f} but no operation told success "
                    "or an unknown outcome asked for it then (refused, withdrawn, or carried out "
                    "twice)",
                    near,
                    timeline.around(t, t),
                )
            )
            continue
        # The candidate whose window closes first: the matching a timeline allows, if any;
        # among unknown outcomes, the one sent last (the likeliest to have just run).
        chosen = min(
            candidates,
            key=lambda op: (op.resp, 0.0) if op.outcome == OK else (math.inf, -op.inv),
        )
        if len(candidates) == 1:
            sure.add(id(chosen))
        candidates.remove(chosen)
        claimed[id(chosen)] = t
    for op in ops:
        if not op.write:
            continue
        verdict.writes += 1
        if op.outcome == OK and id(op) not in claimed:
            verdict.violations.append(
                Violation(
                    "write",
                    f"{op.code} was told success but the controller never carried it out "
                    "in its window",
                    [op],
                    timeline.around(op.inv, op.resp),
                )
            )
    return claimed


def _judge_order(
    ops: Sequence[Op], claimed: dict[int, float], sure: set[int], verdict: Verdict
) -> None:
    """Only matches no other op could have made count: identical commands of several
    consumers (CD, CG) may be told apart by their times alone, and a guess is no evidence."""
    per: dict[str, list[Op]] = defaultdict(list)
    for op in ops:
        if op.write and id(op) in sure:
            per[op.consumer].append(op)
    for consumer_ops in per.values():
        consumer_ops.sort(key=lambda op: op.seq)
        for before, after in itertools.pairwise(consumer_ops):
            if claimed[id(after)] < claimed[id(before)]:
                verdict.violations.append(
                    Violation(
                        "order",
                        f"{after.consumer}'s op {after.seq} took effect before its op "
                        f"{before.seq}, sent earlier",
                        [before, after],
                    )
                )


def judge(
    entries: Iterable[dict[str, Any]], ops: Sequence[Op], *, since: float = -math.inf
) -> Verdict:
    """Check ``ops`` against the journal ``entries``; commands carried out before ``since``
    (the run's setup) are not matched to ops."""
    timeline = Timeline(entries)
    verdict = Verdict()
    for op in ops:
        if not op.write:
            _judge_read(timeline, op, verdict)
    codes = {op.code for op in ops if op.write}
    sure: set[int] = set()
    claimed = _judge_writes(timeline, ops, codes, since, verdict, sure)
    _judge_order(ops, claimed, sure, verdict)
    return verdict
