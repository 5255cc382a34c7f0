"""Group B, motion commands: homing, moves to points or coordinates, and jogging.

BA homes, BB moves to points of a PNT file, BC to given coordinates, BD by a delta; BE starts a
jog, BF keeps it going, BG stops it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Self

from robostar.commands.base import (
    ChannelOnly,
    NoData,
    NumberField,
    encode_axes,
    encode_file_of_kind,
    file_arg,
    read_axes,
    read_file_of_kind,
    set_fields,
)
from robostar.errors import FieldError
from robostar.protocol.fields import (
    COORD_WIDTH,
    FLAG_REJECTED,
    FLAG_UNSUPPORTED,
    FileName,
    Reader,
    check_range,
    encode_channel,
)
from robostar.types import CoordSystem, JogDirection, MotionType

__all__ = [
    "Home",
    "JogContinue",
    "JogStart",
    "JogStop",
    "Move",
    "MoveBy",
    "MoveToPoint",
]

POINT_WIDTH = 4
MAX_LOCAL_POINT = 9999
POINT = NumberField("point", POINT_WIDTH, 0, MAX_LOCAL_POINT)
POINT2 = NumberField("point2", POINT_WIDTH, 0, MAX_LOCAL_POINT)
MAX_AXES = 6


def _digit(command: str, field: str, value: int, lo: int, hi: int, flag: int) -> bytes:
    """A one-byte ASCII digit code; ``flag`` is what the manual says a controller answers."""
    return b"%d" % check_range(command, field, value, lo, hi, flag=flag)


def points_for(motion: MotionType) -> int:
    """How many points BC carries: a target (JMOV, LMOV), via + target (AMOV), two vias (CMOV)."""
    return 2 if motion in (MotionType.ARC, MotionType.CIRCLE) else 1


def _encode_axes(command: str, field: str, values: Sequence[float]) -> bytes:
    if isinstance(values, str | bytes) or not isinstance(values, Sequence):
        raise FieldError(command, field, "must be a sequence of axis values")
    check_range(command, f"{field} axis count", len(values), 1, MAX_AXES)
    return encode_axes(command, values, field, exact=True)


def _read_points(reader: Reader, names: Sequence[str], field: str) -> tuple[tuple[float, ...], ...]:
    """One point per name, of equal axis count, 10 bytes per axis, from the rest of the packet."""
    count = len(names)
    size = reader.remaining
    axes, extra = divmod(size, count * COORD_WIDTH)
    if extra or not 1 <= axes <= MAX_AXES:
        raise FieldError(
            reader.command,
            field,
            f"{size} bytes is not {count} point(s) of 1-{MAX_AXES} axes x {COORD_WIDTH} bytes",
        )
    return tuple(read_axes(reader, axes, name) for name in names)


@dataclass(frozen=True, slots=True)
class Home(ChannelOnly, NoData):
    """BA: return a channel's robot to its origin (homing)."""

    CODE = "BA"
    CHANGES_STATE = True
    channel: int


@dataclass(frozen=True, slots=True, init=False)
class MoveToPoint(NoData):
    """BB: move to a point of a PNT file, or along an arc or circle through two of its points.

    JOINT/LINEAR: ``point`` is the target and ``point2`` is 0. ARC: via ``point`` to target
    ``point2``. CIRCLE: through the via points ``point`` and ``point2``. ``file`` may be given as
    a string (``"P1.PNT"``); it is kept as a FileName.
    """

    CODE = "BB"
    CHANGES_STATE = True
    channel: int
    file: FileName
    motion: MotionType
    point: int
    point2: int

    def __init__(
        self,
        channel: int,
        file: FileName | str,
        motion: MotionType,
        point: int,
        point2: int = 0,
    ) -> None:
        set_fields(
            self, channel=channel, file=file_arg(file), motion=motion, point=point, point2=point2
        )

    @classmethod
    def _check_point2(cls, motion: int, point2: int) -> None:
        # The manual's example sends "0000" as Point Num 2 for a one-point move.
        if motion in (MotionType.JOINT, MotionType.LINEAR) and point2 != 0:
            raise FieldError(cls.CODE, "point2", f"must be 0 for a {MotionType(motion).name} move")

    def encode_params(self) -> bytes:
        channel = encode_channel(self.CODE, self.channel)
        name = encode_file_of_kind(self.CODE, self.file, "PNT")
        motion = _digit(self.CODE, "motion", self.motion, 0, 3, FLAG_REJECTED)
        point = POINT.encode(self.CODE, self.point)
        point2 = POINT2.encode(self.CODE, self.point2)
        self._check_point2(self.motion, self.point2)
        return channel + name + motion + point + point2

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        name = read_file_of_kind(reader, "PNT")
        motion = reader.enum("motion", MotionType)
        point = POINT.read(reader)
        point2 = POINT2.read(reader)
        cls._check_point2(motion, point2)
        return cls(channel, name, motion, point, point2)


@dataclass(frozen=True, slots=True)
class Move(NoData):
    """BC: move to coordinates, in joint angles or XY.

    ``points`` holds one target (JOINT, LINEAR), via + target (ARC) or two via points (CIRCLE),
    each with the same number of axes (1-6).
    """

    CODE = "BC"
    CHANGES_STATE = True
    channel: int
    motion: MotionType
    coords: CoordSystem
    points: tuple[tuple[float, ...], ...]

    def encode_params(self) -> bytes:
        channel = encode_channel(self.CODE, self.channel)
        motion = _digit(self.CODE, "motion", self.motion, 0, 3, FLAG_UNSUPPORTED)
        coords = _digit(self.CODE, "coords", self.coords, 0, 1, FLAG_REJECTED)
        points = self.points
        if isinstance(points, str | bytes) or not isinstance(points, Sequence):
            raise FieldError(self.CODE, "points", "must be a sequence of points")
        need = points_for(MotionType(self.motion))
        if len(points) != need:
            raise FieldError(
                self.CODE,
                "points",
                f"a {MotionType(self.motion).name} move takes {need} point(s), not {len(points)}",
            )
        data = [_encode_axes(self.CODE, f"point {i + 1}", p) for i, p in enumerate(points)]
        if len({len(d) for d in data}) != 1:
            raise FieldError(self.CODE, "points", "every point needs the same number of axes")
        return channel + motion + coords + b"".join(data)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        motion = reader.enum("motion", MotionType, flag=FLAG_UNSUPPORTED)
        coords = reader.enum("coords", CoordSystem)
        names = [f"point {i + 1}" for i in range(points_for(motion))]
        return cls(channel, motion, coords, _read_points(reader, names, "points"))


@dataclass(frozen=True, slots=True)
class MoveBy(NoData):
    """BD: move by a delta from the current position (JOINT or LINEAR), per axis (1-6)."""

    CODE = "BD"
    CHANGES_STATE = True
    channel: int
    motion: MotionType
    coords: CoordSystem
    delta: tuple[float, ...]

    def encode_params(self) -> bytes:
        return (
            encode_channel(self.CODE, self.channel)
            + _digit(self.CODE, "motion", self.motion, 0, 1, FLAG_UNSUPPORTED)
            + _digit(self.CODE, "coords", self.coords, 0, 1, FLAG_REJECTED)
            + _encode_axes(self.CODE, "delta", self.delta)
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        motion = MotionType(reader.code("motion", 0, 1, flag=FLAG_UNSUPPORTED))
        coords = reader.enum("coords", CoordSystem)
        (delta,) = _read_points(reader, ["delta"], "delta")
        return cls(channel, motion, coords, delta)


@dataclass(frozen=True, slots=True)
class JogStart(NoData):
    """BE: start jogging one axis (1-6) in a direction; keep it going with BF within 500 ms."""

    CODE = "BE"
    CHANGES_STATE = True
    channel: int
    axis: int
    direction: JogDirection
    motion: MotionType

    def encode_params(self) -> bytes:
        return (
            encode_channel(self.CODE, self.channel)
            # The wire numbers axes from '0'; the pendant from 1.
            + b"%d" % (check_range(self.CODE, "axis", self.axis, 1, MAX_AXES) - 1)
            + _digit(self.CODE, "direction", self.direction, 0, 1, FLAG_REJECTED)
            + _digit(self.CODE, "motion", self.motion, 0, 1, FLAG_REJECTED)
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        axis = reader.code("axis", 0, MAX_AXES - 1) + 1
        direction = reader.enum("direction", JogDirection)
        motion = MotionType(reader.code("motion", 0, 1))
        return cls(channel, axis, direction, motion)


@dataclass(frozen=True, slots=True)
class JogContinue(ChannelOnly, NoData):
    """BF: keep a jog going (must come within 500 ms of the last BE/BF, or the robot stops)."""

    CODE = "BF"
    CHANGES_STATE = True
    channel: int


@dataclass(frozen=True, slots=True)
class JogStop(ChannelOnly, NoData):
    """BG: stop a jog (``STX FF 'B' 'G' channel ETX LRC``; the manual's table is missing)."""

    CODE = "BG"
    CHANGES_STATE = True
    channel: int
