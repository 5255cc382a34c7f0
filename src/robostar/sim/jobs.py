"""The job language subset the simulator runs, and the runner that steps through a job.

One statement per line (a line is a step, numbered from 1)::

    MAIN                      start of the job (no-op)
    JMOV P<n> / LMOV P<n>     move to point n of the PNT file named like the job
    DELAY <ms>                wait
    OUT <port>,<contact>,<0|1>        set an output contact
    WAIT IN <port>,<contact>,<0|1>    wait until an input contact has that state
    <label>:                  a jump target (no-op)
    GOTO <label>              jump
    END / EOP                 end of the job

Keywords are case-insensitive. Any other line is one step that does nothing. Every step takes at
least STEP_TIME of model time, so a job that loops forever still lets time pass.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

__all__ = [
    "STEP_TIME",
    "JobHost",
    "JobRunner",
    "JobSyntaxError",
    "Op",
    "Program",
    "Step",
    "parse_job",
]

STEP_TIME = 0.02
"""Model seconds one step takes at least."""
_EPS = 1e-9


class JobSyntaxError(Exception):
    """A line of a job does not parse; ``line`` is its step number (1-based)."""

    def __init__(self, line: int, message: str):
        self.line = line
        self.message = message
        super().__init__(f"line {line}: {message}")


class Op(enum.Enum):
    NOP = "nop"
    END = "end"
    JMOV = "jmov"
    LMOV = "lmov"
    DELAY = "delay"
    OUT = "out"
    WAIT = "wait in"
    GOTO = "goto"


@dataclass(frozen=True, slots=True)
class Step:
    """One parsed line: the operation and its integer arguments (GOTO: the target step index)."""

    op: Op
    args: tuple[int, ...] = ()


@dataclass(frozen=True, slots=True)
class Program:
    steps: tuple[Step, ...]


_LABEL = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*:")
_POINT = re.compile(r"P\s*(\d{1,4})", re.IGNORECASE)
_INT = re.compile(r"\d{1,7}")
_IO = re.compile(r"(\d{1,2})\s*,\s*(\d{1,2})\s*,\s*([01])")


def _io_args(line: int, text: str, what: str) -> tuple[int, int, int]:
    match = _IO.fullmatch(text)
    if not match:
        raise JobSyntaxError(line, f"{what} needs <port>,<contact>,<0|1>, not {text!r}")
    port, contact, value = (int(g) for g in match.groups())
    if not 0 <= port <= 4:
        raise JobSyntaxError(line, f"{what}: port {port} is not 0..4")
    if not 0 <= contact <= 15:
        raise JobSyntaxError(line, f"{what}: contact {contact} is not 0..15")
    return port, contact, value


def parse_job(lines: Sequence[str]) -> Program:
    """Parse a job's lines; JobSyntaxError names the first bad line."""
    labels: dict[str, int] = {}
    pending: list[tuple[int, str]] = []  # (step index, label) of GOTOs to resolve
    steps: list[Step] = []
    for index, raw in enumerate(lines):
        number = index + 1
        text = raw.strip()
        word, _, rest = text.partition(" ")
        keyword = word.upper()
        rest = rest.strip()
        label = _LABEL.fullmatch(text)
        if label:
            name = label.group(1).upper()
            if name in labels:
                raise JobSyntaxError(number, f"label {label.group(1)} is defined twice")
            labels[name] = index
            steps.append(Step(Op.NOP))
        elif keyword in ("END", "EOP") and not rest:
            steps.append(Step(Op.END))
        elif keyword in ("JMOV", "LMOV"):
            point = _POINT.fullmatch(rest)
            if not point:
                raise JobSyntaxError(number, f"{keyword} needs a point, P<n>, not {rest!r}")
            steps.append(Step(Op.JMOV if keyword == "JMOV" else Op.LMOV, (int(point.group(1)),)))
        elif keyword == "DELAY":
            if not _INT.fullmatch(rest):
                raise JobSyntaxError(number, f"DELAY needs milliseconds, not {rest!r}")
            steps.append(Step(Op.DELAY, (int(rest),)))
        elif keyword == "OUT":
            steps.append(Step(Op.OUT, _io_args(number, rest, "OUT")))
        elif keyword == "WAIT":
            sub, _, io = rest.partition(" ")
            if sub.upper() != "IN":
                raise JobSyntaxError(number, f"WAIT needs IN <port>,<contact>,<0|1>, not {rest!r}")
            steps.append(Step(Op.WAIT, _io_args(number, io.strip(), "WAIT IN")))
        elif keyword == "GOTO":
            if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", rest):
                raise JobSyntaxError(number, f"GOTO needs a label, not {rest!r}")
            pending.append((index, rest.upper()))
            steps.append(Step(Op.GOTO))
        else:
            steps.append(Step(Op.NOP))
    for index, name in pending:
        if name not in labels:
            raise JobSyntaxError(index + 1, f"GOTO {name}: no such label")
        steps[index] = Step(Op.GOTO, (labels[name],))
    return Program(tuple(steps))


class JobHost(Protocol):
    """What the runner needs from the model. ``job_move``/``job_output`` return False when the
    step failed (the host has raised an alarm and stopped the job)."""

    def job_move(self, channel: int, linear: bool, point: int, line: int) -> bool: ...

    def job_moving(self, channel: int) -> bool: ...

    def job_output(self, channel: int, port: int, contact: int, on: bool, line: int) -> bool: ...

    def job_input(self, port: int, contact: int) -> bool: ...


class _Phase(enum.Enum):
    TIMER = "timer"
    MOVING = "moving"
    WAITING = "waiting"


class JobRunner:
    """Runs one selected job on one channel, in model time."""

    def __init__(self, channel: int, program: Program):
        self.channel = channel
        self.program = program
        self.pc = 0
        self.running = False
        self.step_mode = False
        self._phase: _Phase | None = None
        self._until = 0.0

    @property
    def step(self) -> int:
        """The current step number as ED reports it (1 = the first line)."""
        return self.pc + 1

    def start(self, step_mode: bool) -> None:
        self.running = True
        self.step_mode = step_mode

    def hold(self) -> None:
        """Stop; the interrupted step starts over when the job is started again."""
        self.running = False
        self._phase = None

    def reset(self) -> None:
        self.hold()
        self.pc = 0

    def next_event(self, now: float) -> float | None:
        """Model time at which :meth:`tick` has something to do (None: nothing timed)."""
        if not self.running:
            return None
        if self._phase is None:
            return now
        return self._until if self._until > now else None

    def tick(self, host: JobHost, now: float) -> None:
        """Carry out every step transition due at model time ``now``."""
        steps = self.program.steps
        while self.running:
            step = steps[self.pc]
            if self._phase is None and not self._begin(host, step, now):
                return
            if now < self._until - _EPS:
                return
            if self._phase is _Phase.MOVING and host.job_moving(self.channel):
                return
            if self._phase is _Phase.WAITING:
                port, contact, value = step.args
                if host.job_input(port, contact) != bool(value):
                    return
            self._phase = None
            self.pc = step.args[0] if step.op is Op.GOTO else self.pc + 1
            if self.pc >= len(steps):
                self.running = False
                self.pc = 0
            elif self.step_mode:
                self.running = False

    def _begin(self, host: JobHost, step: Step, now: float) -> bool:
        """Start a step; False when the job ended or stopped on it."""
        line = self.pc + 1
        self._until = now + STEP_TIME
        if step.op is Op.END:
            self.running = False
            self.pc = 0
            return False
        if step.op in (Op.JMOV, Op.LMOV):
            if not host.job_move(self.channel, step.op is Op.LMOV, step.args[0], line):
                return False
            self._phase = _Phase.MOVING
        elif step.op is Op.OUT:
            port, contact, value = step.args
            if not host.job_output(self.channel, port, contact, bool(value), line):
                return False
            self._phase = _Phase.TIMER
        elif step.op is Op.WAIT:
            self._phase = _Phase.WAITING
        elif step.op is Op.DELAY:
            self._until = now + max(step.args[0] / 1000.0, STEP_TIME)
            self._phase = _Phase.TIMER
        else:
            self._phase = _Phase.TIMER
        return True
