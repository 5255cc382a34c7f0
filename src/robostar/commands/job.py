"""Groups D and E, job commands: servo, job selection and mode, the running job's step and name.

DB turns the servo on or off and DC selects the job (both two-phase); EA sets auto or step mode;
ED reads the running step and EF the running job's name.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Self

from robostar.commands.base import (
    FILE_NAME_WIDTH,
    ChannelOnly,
    Command,
    NoData,
    NumberAnswer,
    NumberField,
    Shape,
    encode_file_of_kind,
    file_arg,
    read_file_of_kind,
    set_fields,
)
from robostar.errors import FieldError
from robostar.protocol.fields import (
    FileName,
    Reader,
    encode_channel,
    encode_code,
)
from robostar.types import JobMode

__all__ = ["ReadJobName", "ReadJobStep", "SelectJob", "Servo", "SetJobMode"]

WAIT_WIDTH = 2
MAX_WAIT = 99
WAIT = NumberField("expected wait", WAIT_WIDTH, 0, MAX_WAIT)
STEP_WIDTH = 4
MAX_STEP = 9999


class _WaitAnswer(Command[int]):
    """A two-phase answer: ``FLAG wait`` (2 digits, seconds), then a bare ``FLAG``."""

    def decode_answer(self, packets: Sequence[bytes]) -> int:
        self.expect_packets(packets, 2)
        first = self.reader(packets[0])
        wait = WAIT.read(first)
        first.end()
        self.bare_flags(packets[1:])
        return wait

    def encode_answer(self, result: int) -> list[bytes]:
        return [self.ok(WAIT.encode(self.CODE, result)), self.ok()]


@dataclass(frozen=True, slots=True)
class Servo(_WaitAnswer):
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


@dataclass(frozen=True, slots=True, init=False)
class SelectJob(_WaitAnswer):
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
        set_fields(self, channel=channel, file=file_arg(file))

    def encode_params(self) -> bytes:
        channel = encode_channel(self.CODE, self.channel)
        return channel + encode_file_of_kind(self.CODE, self.file, "JOB")

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        return cls(channel, read_file_of_kind(reader, "JOB"))


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
        return encode_channel(self.CODE, self.channel) + encode_code(
            self.CODE, "mode", self.mode, 0, 1
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        return cls(channel, reader.enum("mode", JobMode))


@dataclass(frozen=True, slots=True)
class ReadJobStep(ChannelOnly, NumberAnswer):
    """ED: read the step number the channel's job is at (4 digits, ``"0027"``)."""

    CODE = "ED"
    ANSWER = NumberField("step", STEP_WIDTH, 0, MAX_STEP)
    channel: int


@dataclass(frozen=True, slots=True)
class ReadJobName(ChannelOnly, Command[FileName | None]):
    """EF: read the name of the channel's job, or None when none is selected.

    The answer is 12 bytes, left-aligned (``"RS.JOB      "``); all spaces means no job.
    """

    CODE = "EF"
    channel: int

    def decode_answer(self, packets: Sequence[bytes]) -> FileName | None:
        r = self.single(packets)
        name = r.name(FILE_NAME_WIDTH, "file")
        r.end()
        return name if str(name) else None

    def encode_answer(self, result: FileName | None) -> list[bytes]:
        if result is None:
            return [self.ok(b" " * FILE_NAME_WIDTH)]
        return [self.ok(result.encode(self.CODE, "file", FILE_NAME_WIDTH, align="<"))]
