"""The command handshake: command code and parameters in holding registers, then a sequence
number; each new sequence number runs its command once (sans-IO: registers in, a request out).

| code | name | P1 | P2 | P3 | command(s) |
|---|---|---|---|---|---|
| 1 | ``select_job`` | channel | JOB number | | DC (the file FD lists with that number) |
| 2 | ``start_job`` | channel | | | CC |
| 3 | ``run_job`` | channel | JOB number | | DC, then CC |
| 4 | ``stop_job`` | channel | | | CD (a stop) |
| 5 | ``servo`` | channel | 1 on, 0 off | | DB |
| 6 | ``reset_alarms`` | | | | CG |
| 7 | ``speed`` | channel | 0-1000 | | CB |
| 8 | ``output`` | port 0-4 | contact 0-15 | 1 on, 0 off | GC |
| 9 | ``global_int`` | index | value, high word | value, low word | GW (int32) |
| 10 | ``global_float`` | index | value, high word | value, low word | GW (float32) |
| 11 | ``estop`` | | | | CF (a stop) |
| 12 | ``jog_stop`` | channel | | | BG (a stop) |
| 13 | ``reset_job`` | channel | | | CE |
| 14 | ``home`` | channel | | | BA (origin return; done when it has started) |
| 15 | ``stop_homing`` | channel | | | CI (a stop) |

Stops (``stop_job``, ``estop``, ``jog_stop``, ``stop_homing``) need no lease and go ahead of
everything on the line, as on every face; they also run while another command of the PLC is
still running.
"""

from __future__ import annotations

import enum
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from robostar.commands.base import Command
from robostar.commands.control import (
    EmergencyStop,
    ResetAlarms,
    ResetJob,
    SetSpeed,
    StartJob,
    StopHoming,
    StopJob,
)
from robostar.commands.io import SetOutput
from robostar.commands.job import Servo
from robostar.commands.motion import Home, JogStop
from robostar.commands.variables import WriteGlobalFloat, WriteGlobalInt
from robostar.errors import UsageError
from robostar.serve.faces.modbus.layout import HR

__all__ = [
    "CODES",
    "STOP_NAMES",
    "Request",
    "Sequencer",
    "Take",
    "parse_request",
]


def _bool(value: int, name: str) -> bool:
    if value not in (0, 1):
        raise UsageError(f"{name}: {value} is not 0 (off) or 1 (on)")
    return value == 1


def _int32(high: int, low: int) -> int:
    return int(struct.unpack(">i", struct.pack(">HH", high, low))[0])


def _float32(high: int, low: int) -> float:
    """The PLC's REAL as the decimal it meant: the shortest one that is the same float32.

    A float32 holds few decimals exactly (0.1 arrives as 0.10000000149011612), and GW refuses
    a value finer than 0.001 rather than round it; so 0.1 is taken as 0.1, but 0.1234 (a
    float32 of its own) is still refused as finer than the field."""
    data = struct.pack(">HH", high, low)
    value = float(struct.unpack(">f", data)[0])
    if value != value or value in (float("inf"), float("-inf")):
        raise UsageError("value: not a finite float")
    for digits in range(1, 10):  # 9 significant digits always read back as the same float32
        shortest = float(f"{value:.{digits}g}")
        if struct.pack(">f", shortest) == data:
            return shortest
    return value


@dataclass(frozen=True)
class Request:
    """A command the PLC asked for: its name, the line command(s) it becomes, and for the
    job commands the JOB number that the face resolves to a file first (then ``commands`` is
    empty and ``channel``/``job`` say what to select, ``start`` whether to start it after)."""

    sequence: int
    code: int
    name: str
    commands: tuple[Command[Any], ...] = ()
    channel: int = 0
    job: int | None = None
    start: bool = False

    @property
    def is_stop(self) -> bool:
        return self.name in STOP_NAMES


def _plain(
    name: str, make: Callable[[Sequence[int]], Command[Any]]
) -> Callable[[int, int, Sequence[int]], Request]:
    def build(sequence: int, code: int, p: Sequence[int]) -> Request:
        return Request(sequence, code, name, (make(p),))

    return build


def _job(name: str, start: bool) -> Callable[[int, int, Sequence[int]], Request]:
    def build(sequence: int, code: int, p: Sequence[int]) -> Request:
        StartJob(p[0]).encode()  # the channel's range, before the JOB is looked up
        if not 0 <= p[1] <= 200:
            raise UsageError(f"JOB number: {p[1]} is not 0-200")
        return Request(sequence, code, name, (), channel=p[0], job=p[1], start=start)

    return build


CODES: dict[int, tuple[str, Callable[[int, int, Sequence[int]], Request]]] = {
    1: ("select_job", _job("select_job", start=False)),
    2: ("start_job", _plain("start_job", lambda p: StartJob(p[0]))),
    3: ("run_job", _job("run_job", start=True)),
    4: ("stop_job", _plain("stop_job", lambda p: StopJob(p[0]))),
    5: ("servo", _plain("servo", lambda p: Servo(p[0], _bool(p[1], "P2 (on)")))),
    6: ("reset_alarms", _plain("reset_alarms", lambda p: ResetAlarms())),
    7: ("speed", _plain("speed", lambda p: SetSpeed(p[0], p[1]))),
    8: ("output", _plain("output", lambda p: SetOutput(p[0], p[1], _bool(p[2], "P3 (on)")))),
    9: ("global_int", _plain("global_int", lambda p: WriteGlobalInt(p[0], _int32(p[1], p[2])))),
    10: (
        "global_float",
        _plain("global_float", lambda p: WriteGlobalFloat(p[0], _float32(p[1], p[2]))),
    ),
    11: ("estop", _plain("estop", lambda p: EmergencyStop())),
    12: ("jog_stop", _plain("jog_stop", lambda p: JogStop(p[0]))),
    13: ("reset_job", _plain("reset_job", lambda p: ResetJob(p[0]))),
    14: ("home", _plain("home", lambda p: Home(p[0]))),
    15: ("stop_homing", _plain("stop_homing", lambda p: StopHoming(p[0]))),
}
"""Every command the face can take, by code (the allowlist picks among them by name)."""

NAMES = frozenset(name for name, _ in CODES.values())
STOP_NAMES = frozenset(("stop_job", "estop", "jog_stop", "stop_homing"))


def parse_request(registers: Sequence[int]) -> Request:
    """The request in the command block ``registers`` (HR 0-9); UsageError (or FieldError)
    naming what is wrong, before anything reaches the line."""
    code, sequence = registers[HR.COMMAND], registers[HR.SEQUENCE]
    params = registers[HR.PARAMS : HR.PARAMS + HR.PARAM_COUNT]
    entry = CODES.get(code)
    if entry is None:
        raise UsageError(f"unknown command code {code} (codes: {', '.join(map(str, CODES))})")
    request = entry[1](sequence, code, params)
    for command in request.commands:
        command.encode()  # every field's range, as the wire would refuse it
    return request


class Take(enum.Enum):
    """What a write of the sequence register means."""

    NOTHING = "nothing"
    """0, or the sequence number last taken: the same block written again."""
    RUN = "run"
    BASELINE = "baseline"
    """The first sequence number since the face started: it may be a command the face ran
    before a restart, rewritten by a PLC that writes its block every cycle, so it is refused
    (reason ``restarted``), never run; the PLC writes a new number to run its command."""


class Sequencer:
    """Which writes of the command block start a command: a sequence number other than 0 and
    other than the last one taken. The same block written twice runs once, across a restart
    of the face too (see :attr:`Take.BASELINE`)."""

    def __init__(self) -> None:
        self.last: int | None = None

    def take(self, sequence: int) -> Take:
        """What ``sequence`` means (and remember it unless it means nothing)."""
        if sequence == 0 or sequence == self.last:
            return Take.NOTHING
        first, self.last = self.last is None, sequence
        return Take.BASELINE if first else Take.RUN
