"""Group C, control commands: speed, job start/stop/reset, emergency stop, alarms, restart.

CA/CB read and set the speed; CC, CD, CE start, stop and reset the job; CF stops everything, CG
resets alarms; CI stops homing; CJ restarts the controller; CX/CZ set and read the reference axis.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Self

from robostar.commands.base import (
    ChannelOnly,
    Command,
    NoData,
    NoParams,
    NumberAnswer,
    NumberField,
    Shape,
)
from robostar.errors import FieldError
from robostar.protocol.fields import Reader, encode_channel

__all__ = [
    "EmergencyStop",
    "ReadReferenceAxis",
    "ReadSpeed",
    "ResetAlarms",
    "ResetJob",
    "Restart",
    "SetReferenceAxis",
    "SetSpeed",
    "StartJob",
    "StopHoming",
    "StopJob",
]

SPEED_WIDTH = 4
MAX_SPEED = 1000
"""1000 is 100 % of each axis's Mv."""
SPEED = NumberField("speed", SPEED_WIDTH, 0, MAX_SPEED)
REFERENCE_AXES = (1, 4)
"""CX/CZ: X (1) or W (4) is the reference for interpolated moves."""


def _reference_axis(command: str, axis: int) -> int:
    if isinstance(axis, bool) or not isinstance(axis, int) or axis not in REFERENCE_AXES:
        raise FieldError(command, "axis", f"{axis!r} is not 1 (X) or 4 (W)")
    return axis


def _read_reference_axis(reader: Reader) -> int:
    return _reference_axis(reader.command, reader.code("axis", 0, 9))


@dataclass(frozen=True, slots=True)
class ReadSpeed(ChannelOnly, NumberAnswer):
    """CA: read a channel's speed, 0-1000 (1000 = 100 % of Mv); answered as 4 digits."""

    CODE = "CA"
    ANSWER = SPEED
    channel: int


@dataclass(frozen=True, slots=True)
class SetSpeed(NoData):
    """CB: set a channel's speed, 0-1000 (1000 = 100 % of Mv), sent as 4 digits."""

    CODE = "CB"
    CHANGES_STATE = True
    channel: int
    speed: int

    def encode_params(self) -> bytes:
        return encode_channel(self.CODE, self.channel) + SPEED.encode(self.CODE, self.speed)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        return cls(channel, SPEED.read(reader))


@dataclass(frozen=True, slots=True)
class StartJob(ChannelOnly, NoData):
    """CC: start the channel's selected job (DC first; fails before homing is done)."""

    CODE = "CC"
    CHANGES_STATE = True
    channel: int


@dataclass(frozen=True, slots=True)
class StopJob(ChannelOnly, NoData):
    """CD: stop the channel's running job."""

    CODE = "CD"
    CHANGES_STATE = True
    channel: int


@dataclass(frozen=True, slots=True)
class ResetJob(ChannelOnly, NoData):
    """CE: set the channel's job back to its first step (MAIN); servo off only.

    Two-phase: a bare flag when the request is taken, another when the reset is done.
    """

    CODE = "CE"
    SHAPE = Shape.TWO_PHASE
    CHANGES_STATE = True
    channel: int


@dataclass(frozen=True, slots=True)
class EmergencyStop(NoParams, NoData):
    """CF: online emergency stop; raises the "Host Emergency" alarm, which CG clears."""

    CODE = "CF"
    CHANGES_STATE = True


@dataclass(frozen=True, slots=True)
class ResetAlarms(NoParams, NoData):
    """CG: reset the controller's alarms."""

    CODE = "CG"
    CHANGES_STATE = True


@dataclass(frozen=True, slots=True)
class StopHoming(ChannelOnly, NoData):
    """CI: stop a channel's homing (origin return)."""

    CODE = "CI"
    CHANGES_STATE = True
    channel: int


@dataclass(frozen=True, slots=True)
class Restart(NoParams, NoData):
    """CJ: restart the controller (servo off only), when CG cannot clear a fatal alarm."""

    CODE = "CJ"
    CHANGES_STATE = True


@dataclass(frozen=True, slots=True)
class SetReferenceAxis(NoData):
    """CX: make axis 1 (X) or 4 (W) the reference of interpolated moves (desktop robots)."""

    CODE = "CX"
    CHANGES_STATE = True
    channel: int
    axis: int

    def encode_params(self) -> bytes:
        # Unlike BE, the manual sends the axis number itself ('1' or '4'), not axis - 1.
        return encode_channel(self.CODE, self.channel) + b"%d" % _reference_axis(
            self.CODE, self.axis
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        return cls(channel, _read_reference_axis(reader))


@dataclass(frozen=True, slots=True)
class ReadReferenceAxis(ChannelOnly, Command[int]):
    """CZ: read the reference axis of interpolated moves: 1 (X) or 4 (W)."""

    CODE = "CZ"
    channel: int

    def decode_answer(self, packets: Sequence[bytes]) -> int:
        r = self.single(packets)
        axis = _read_reference_axis(r)
        r.end()
        return axis

    def encode_answer(self, result: int) -> list[bytes]:
        return [self.ok(b"%d" % _reference_axis(self.CODE, result))]
