"""Model values as the pages and the event stream show them: plain JSON, units, and quality."""

from __future__ import annotations

from typing import Any

from robostar.serve.jsonable import jsonable
from robostar.serve.model import Quality, Sample
from robostar.types import PositionKind, RobotType

__all__ = ["axis_unit", "change_json", "sample_json"]


def sample_json(sample: Sample | None) -> dict[str, Any]:
    """``{"value", "at", "quality"}``; a value never read is ``None`` with quality "line down"."""
    if sample is None:
        return {"value": None, "at": None, "quality": Quality.LINE_DOWN.value}
    return {"value": jsonable(sample.value), "at": sample.at, "quality": sample.quality.value}


def change_json(line: str, key: str, sample: Sample) -> dict[str, Any]:
    return {"line": line, "key": key, **sample_json(sample)}


def axis_unit(kind: PositionKind, axis: int, robot: RobotType | None) -> str:
    """The unit of one axis of a position: mm, degrees or pulses.

    A SCARA's joints 1, 2 and 4 turn (degrees) and joint 3 slides (mm); in XY coordinates the
    4th value is the tool's rotation. Every axis of a cartesian robot slides."""
    if kind is PositionKind.PULSE:
        return "pulse"
    if axis == 4 and (kind is PositionKind.XY or robot is RobotType.SCARA):
        return "°"
    if kind is PositionKind.ANGLE and robot is RobotType.SCARA and axis in (1, 2):
        return "°"
    return "mm"
