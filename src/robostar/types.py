"""Result types and enums that read like the N1 pendant.

Channels are numbered 1-3 and axes 1-6 as the pendant shows them; the wire's ``'0'..'2'``
codes stay inside the codecs. All types are frozen and hashable.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import ClassVar

__all__ = [
    "Alarm",
    "AlarmRecord",
    "ArmForm",
    "ChannelInfo",
    "ChannelStatus",
    "ControllerInfo",
    "CoordSystem",
    "FileRecord",
    "GlobalKind",
    "IOState",
    "JobFile",
    "JobMode",
    "JogDirection",
    "MotionType",
    "Point",
    "PointFile",
    "Position",
    "PositionKind",
    "RobotType",
]


class RobotType(enum.IntEnum):
    """Channel type as AD reports it."""

    XY = 0
    SCARA = 1
    TRANSFER = 2
    CYLINDER = 3
    BACKGROUND_TASK = 4
    NOT_DEFINED = 5


class MotionType(enum.IntEnum):
    """Motion type of BB/BC/BD/BE: JMOV, LMOV, AMOV, CMOV."""

    JOINT = 0
    LINEAR = 1
    ARC = 2
    CIRCLE = 3


class CoordSystem(enum.IntEnum):
    """Coordinate system of BC/BD/GR/GW/FA: joint angles (mm on a cartesian robot) or XY."""

    ANGLE = 0
    XY = 1


class PositionKind(enum.IntEnum):
    """AC's data type."""

    PULSE = 0
    ANGLE = 1
    XY = 2


class ArmForm(enum.IntEnum):
    """SCARA arm posture. For GW, ``NONE`` (2) means "keep the robot's current posture"."""

    LEFT = 0
    RIGHT = 1
    NONE = 2


class JogDirection(enum.IntEnum):
    MINUS = 0
    PLUS = 1


class JobMode(enum.IntEnum):
    AUTO = 0
    STEP = 1


class GlobalKind(enum.IntEnum):
    """GR/GW's Type byte."""

    POINT = 0
    INTEGER = 1
    FLOAT = 2


@dataclass(frozen=True, slots=True)
class ChannelStatus:
    """One channel's AA status byte."""

    BY_BITS: ClassVar[tuple[ChannelStatus, ...]]
    """Every status a byte can hold, by its six low bits (``value & 0x3F``), made once."""

    servo_on: bool = False
    origin: bool = False
    alarm: bool = False
    ready: bool = False
    in_position: bool = False
    running: bool = False

    def to_byte(self) -> int:
        return (
            0x80
            | (0x20 if self.servo_on else 0)
            | (0x10 if self.origin else 0)
            | (0x08 if self.alarm else 0)
            | (0x04 if self.ready else 0)
            | (0x02 if self.in_position else 0)
            | (0x01 if self.running else 0)
        )

    @classmethod
    def from_byte(cls, value: int) -> ChannelStatus:
        if cls is ChannelStatus:
            # Frozen and equal field by field: the one made beforehand for these six bits is
            # as good as a new one, and a status read builds none.
            return ChannelStatus.BY_BITS[value & 0x3F]
        return cls._make(value)

    @classmethod
    def _make(cls, value: int) -> ChannelStatus:
        return cls(
            servo_on=bool(value & 0x20),
            origin=bool(value & 0x10),
            alarm=bool(value & 0x08),
            ready=bool(value & 0x04),
            in_position=bool(value & 0x02),
            running=bool(value & 0x01),
        )

    def __str__(self) -> str:
        names = ("servo_on", "origin", "alarm", "ready", "in_position", "running")
        on = [n for n in names if getattr(self, n)]
        return ", ".join(on) if on else "-"


ChannelStatus.BY_BITS = tuple(ChannelStatus._make(bits) for bits in range(0x40))


@dataclass(frozen=True, slots=True)
class Position:
    """A position read with AC: one value per axis in use, and the arm form.

    ``kind`` says the unit: pulses (integers), joint angles (degrees, mm on a cartesian axis) or
    XY coordinates (mm). ``arm`` is meaningful for XY on a SCARA; otherwise it is ``NONE``.
    """

    kind: PositionKind
    axes: tuple[float, ...]
    arm: ArmForm = ArmForm.NONE

    def __getitem__(self, axis: int) -> float:
        """Axis by pendant number (1 = first axis)."""
        if not 1 <= axis <= len(self.axes):
            raise IndexError(f"axis {axis} is not in 1..{len(self.axes)}")
        return self.axes[axis - 1]


@dataclass(frozen=True, slots=True)
class Point:
    """A stored point: a PNT file's local point or a global point.

    ``used`` is the USED flag (the point holds data); ``arm`` the SCARA arm form.
    """

    axes: tuple[float, ...]
    arm: ArmForm = ArmForm.NONE
    used: bool = True


@dataclass(frozen=True, slots=True)
class ChannelInfo:
    """One channel as AD describes it."""

    channel: int
    model: str
    robot_type: RobotType
    max_axes: int
    axes_in_use: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class ControllerInfo:
    """The controller's AD answer."""

    max_channels: int
    name: str
    version: str
    channels: tuple[ChannelInfo, ...] = field(default_factory=tuple)

    def channel(self, number: int) -> ChannelInfo:
        return self.channels[number - 1]


@dataclass(frozen=True, slots=True)
class Alarm:
    """A current alarm, as AB lists it (``"1153 : T/P Emergency"``)."""

    code: int
    text: str

    def __str__(self) -> str:
        return f"{self.code:04d} : {self.text}"


@dataclass(frozen=True, slots=True)
class AlarmRecord:
    """One record of the alarm history (FH).

    ``day``/``hours``/``minutes``/``seconds`` are the controller's work timer when the alarm
    happened; ``channel`` is 1-3, or 9 for all channels.
    """

    page: int
    index: int
    day: int
    hours: int
    minutes: int
    seconds: int
    channel: int
    text: str
    detail: str
    code: int


@dataclass(frozen=True, slots=True)
class FileRecord:
    """One file as FD describes it: job number, name, size in KB, step count."""

    job_number: int
    name: str
    size_kb: int
    steps: int


@dataclass(frozen=True, slots=True)
class IOState:
    """The 16 contacts of one I/O port (GA/GB). ``contacts[0]`` is contact 0."""

    port: int
    contacts: tuple[bool, ...]

    def __getitem__(self, contact: int) -> bool:
        return self.contacts[contact]

    @property
    def on(self) -> tuple[int, ...]:
        """The contact numbers that are on."""
        return tuple(i for i, c in enumerate(self.contacts) if c)

    def __str__(self) -> str:
        return "".join("1" if c else "0" for c in self.contacts)


@dataclass(frozen=True, slots=True)
class JobFile:
    """A JOB file's content as FA downloads it: one string per step, ``MAIN`` to ``EOP``."""

    lines: tuple[str, ...]
    announced: int | None = field(default=None, compare=False)
    """FA's first packet, JOB MAX STEP, as the controller sent it: a count on some controllers,
    the capacity (e.g. 2000) on others; kept for whoever wants it, never checked against."""

    @property
    def max_step(self) -> int:
        return len(self.lines)


@dataclass(frozen=True)
class PointFile:
    """A PNT file's content as FA downloads it: local point number -> point.

    ``max_point`` is the highest point number the file holds (FA's first packet).
    """

    points: dict[int, Point]
    announced: int | None = field(default=None, compare=False)
    """FA's first packet, MAX Point, as the controller sent it (the highest point, or the
    file's capacity); kept, never checked against."""

    @property
    def max_point(self) -> int:
        return max(self.points, default=0)
