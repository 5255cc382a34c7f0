"""A channel's axes as the people at the cell name them: the axes the controller says are in
use (AD), each with its name and unit in joint angles and in XY coordinates.

A SCARA turns joints 1 and 2 (degrees), slides Z and turns R; in XY coordinates the same axes
are X, Y (mm), Z (mm) and R (degrees). A cartesian robot's axes are X, Y, Z (mm) and R.
"""

from __future__ import annotations

from dataclasses import dataclass

from robostar.serve.faces.web.views import axis_unit, robot_of
from robostar.serve.line import Line
from robostar.types import PositionKind, RobotType

__all__ = ["AxisName", "channel_axes"]

_XY_NAMES = ("X", "Y", "Z", "R", "A5", "A6")
_SCARA_JOINTS = ("J1", "J2", "Z", "R", "A5", "A6")


@dataclass(frozen=True, slots=True)
class AxisName:
    """One axis: its number (1-6) and its name and unit in angles and in XY."""

    number: int
    joint: str
    joint_unit: str
    xy: str
    xy_unit: str


def channel_axes(line: Line, channel: int) -> list[AxisName]:
    """The channel's axes in use (AD), else as many as its last position has, else 4."""
    robot = robot_of(line, channel)
    numbers: tuple[int, ...] = ()
    info = line.model.get("info")
    for entry in getattr(info.value if info else None, "channels", ()):
        if entry.channel == channel:
            numbers = tuple(entry.axes_in_use)
    if not numbers:
        position = line.model.get(f"ch{channel}/angles") or line.model.get(f"ch{channel}/position")
        count = len(position.value.axes) if position is not None else 4
        numbers = tuple(range(1, count + 1))
    joints = _SCARA_JOINTS if robot is RobotType.SCARA else _XY_NAMES
    return [
        AxisName(
            n,
            joints[n - 1],
            axis_unit(PositionKind.ANGLE, n, robot),
            _XY_NAMES[n - 1],
            axis_unit(PositionKind.XY, n, robot),
        )
        for n in numbers
        if 1 <= n <= 6
    ]
