"""Groups D and E, job commands: servo, job selection and mode, the running job's step and name.

DB turns the servo on or off and DC selects the job (both two-phase); EA sets auto or step mode;
ED reads the running step and EF the running job's name.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Self

from robostar.commands.base import Command, NoData, Shape
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import (
    FLAG_REJECTED,
    FileName,
    Reader,
    check_range,
    encode_channel,
    encode_int,
)
from robostar.types import JobMode

__all__ = ["ReadJobName", "ReadJobStep", "SelectJob", "Servo", "SetJobMode"]

WAIT_WIDTH = 2
MAX_WAIT = 99
STEP_WIDTH = 4
MAX_STEP = 9999
NAME_WIDTH = 12


def _decode_wait(command: Command[int], packets: Sequence[bytes]) -> int:
    """A two-phase answer: ``FLAG wait`` (2 digits, seconds), then a bare ``FLAG``."""
    if len(packets) != 2:
        raise MalformedAnswerError(command.CODE, f"{len(packets)} packets where 2 were expected")
    first = command.reader(packets[0])
    wait = first.number(WAIT_WIDTH, "expected wait", lo=0, hi=MAX_WAIT)
    first.end()
    command.reader(packets[1]).end()
    return wait


def _encode_wait(command: Command[int], wait: int) -> list[bytes]:
    body = encode_int(command.CODE, "expected wait", wait, WAIT_WIDTH, lo=0, hi=MAX_WAIT)
    return [command.ok(body), command.ok()]


@dataclass(frozen=True, slots=True)
class Servo(Command[int]):
    """DB: turn a channel's servo on or off; the result is the expected wait in seconds.

    Two-phase: ``FLAG "02"`` when the request is taken, a bare flag when it is done.
    """

    CODE = "DB"
    SHAPE = Shape.TWO_PHASE
    CHANGES_STATE = True
    channel: int
    on: bool

    def encode_params(self) -> bytes:
        if not isinstance(self.on, bool):
            raise FieldError(self.CODE, "on", f"must be True or False, not {self.on!r}")
        return encode_channel(self.CODE, self.channel) + (b"1" if self.on else b"0")

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        return cls(channel, reader.code("on", 0, 1) == 1)

    def decode_answer(self, packets: Sequence[bytes]) -> int:
        return _decode_wait(self, packets)

    def encode_answer(self, result: int) -> list[bytes]:
        return _encode_wait(self, result)


@dataclass(frozen=True, slots=True, init=False)
class SelectJob(Command[int]):
    """DC: select the JOB file a channel runs; the result is the expected wait in seconds.

    Two-phase like DB. ``file`` may be given as a string (``"RS.JOB"``); it is kept as a
    FileName.
    """

    CODE = "DC"
    SHAPE = Shape.TWO_PHASE
    CHANGES_STATE = True
    channel: int
    file: FileName

    def __init__(self, channel: int, file: FileName | str) -> None:
        object.__setattr__(self, "channel", channel)
        object.__setattr__(self, "file", FileName.parse(file) if isinstance(file, str) else file)

    def encode_params(self) -> bytes:
        channel = encode_channel(self.CODE, self.channel)
        if not isinstance(self.file, FileName):
            raise FieldError(self.CODE, "file", "must be a FileName or a str")
        name = self.file.check(self.CODE, "file", kind="JOB", case_flag=FLAG_REJECTED)
        return channel + name.encode(self.CODE, "file", NAME_WIDTH)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        name = reader.name(NAME_WIDTH, "file")
        return cls(channel, name.check(cls.CODE, "file", kind="JOB", case_flag=FLAG_REJECTED))

    def decode_answer(self, packets: Sequence[bytes]) -> int:
        return _decode_wait(self, packets)

    def encode_answer(self, result: int) -> list[bytes]:
        return _encode_wait(self, result)


@dataclass(frozen=True, slots=True)
class SetJobMode(NoData):
    """EA: set a channel's job mode, AUTO (all steps) or STEP (hold after each step).

    The controller takes it only while the channel is not running.
    """

    CODE = "EA"
    CHANGES_STATE = True
    channel: int
    mode: JobMode

    def encode_params(self) -> bytes:
        return encode_channel(self.CODE, self.channel) + b"%d" % check_range(
            self.CODE, "mode", self.mode, 0, 1
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        return cls(channel, reader.enum("mode", JobMode))


@dataclass(frozen=True, slots=True)
class ReadJobStep(Command[int]):
    """ED: read the step number the channel's job is at (4 digits, ``"0027"``)."""

    CODE = "ED"
    channel: int

    def encode_params(self) -> bytes:
        return encode_channel(self.CODE, self.channel)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        return cls(reader.channel())

    def decode_answer(self, packets: Sequence[bytes]) -> int:
        r = self.single(packets)
        step = r.number(STEP_WIDTH, "step", lo=0, hi=MAX_STEP)
        r.end()
        return step

    def encode_answer(self, result: int) -> list[bytes]:
        return [self.ok(encode_int(self.CODE, "step", result, STEP_WIDTH, lo=0, hi=MAX_STEP))]


@dataclass(frozen=True, slots=True)
class ReadJobName(Command[FileName | None]):
    """EF: read the name of the channel's job, or None when none is selected.

    The answer is 12 bytes, left-aligned (``"RS.JOB      "``); all spaces means no job.
    """

    CODE = "EF"
    channel: int

    def encode_params(self) -> bytes:
        return encode_channel(self.CODE, self.channel)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        return cls(reader.channel())

    def decode_answer(self, packets: Sequence[bytes]) -> FileName | None:
        r = self.single(packets)
        name = r.name(NAME_WIDTH, "file")
        r.end()
        return name if str(name) else None

    def encode_answer(self, result: FileName | None) -> list[bytes]:
        if result is None:
            return [self.ok(b" " * NAME_WIDTH)]
        return [self.ok(result.encode(self.CODE, "file", NAME_WIDTH, align="<"))]
