"""A model value as named leaves with units: what Sparkplug metrics and UNS payloads carry.

The model's values are whole objects (a channel's status, a position, an I/O port). A plant's
SCADA wants one tag per signal, with its engineering unit: ``ch1/status`` becomes
``servo_on``, ``origin``, ...; ``ch1/position`` (XY) becomes ``x``, ``y``, ``z``, ``r`` in mm
and degrees; ``io/in/0`` becomes contacts ``0`` .. ``15``. Lists that are not signals (alarms,
the controller's channels) stay one leaf holding their JSON text.
"""

from __future__ import annotations

import dataclasses
import enum
import json
from dataclasses import dataclass
from typing import Any

from robostar.protocol.fields import FileName
from robostar.serve.jsonable import jsonable
from robostar.types import IOState, Position, PositionKind, RobotType

__all__ = ["Leaf", "Scalar", "axis_names", "axis_unit", "leaves"]

Scalar = bool | int | float | str | None

_XY_NAMES = ("x", "y", "z", "r")


@dataclass(frozen=True)
class Leaf:
    """One signal of a value: ``name`` under the value's key ("" for the value itself)."""

    name: str
    value: Scalar
    unit: str | None = None


def axis_names(kind: PositionKind, count: int) -> tuple[str, ...]:
    """The axes' names: x, y, z, r in XY coordinates; j1.. for joint angles; p1.. for pulses."""
    if kind is PositionKind.XY and count <= len(_XY_NAMES):
        return _XY_NAMES[:count]
    letter = "p" if kind is PositionKind.PULSE else "j"
    return tuple(f"{letter}{axis}" for axis in range(1, count + 1))


def axis_unit(kind: PositionKind, axis: int, robot: RobotType | None) -> str:
    """The unit of pendant axis ``axis``: a SCARA's joints 1, 2 and 4 turn (deg), its joint 3
    slides (mm); in XY coordinates the 4th value is the tool's rotation (deg); every axis of a
    cartesian robot slides (mm)."""
    if kind is PositionKind.PULSE:
        return "pulse"
    if axis == 4 and (kind is PositionKind.XY or robot is RobotType.SCARA):
        return "deg"
    if kind is PositionKind.ANGLE and robot is RobotType.SCARA and axis in (1, 2):
        return "deg"
    return "mm"


def _scalar(value: Any) -> Scalar:
    if isinstance(value, enum.Enum):
        return value.name.lower()
    if isinstance(value, FileName):
        return str(value)
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return json.dumps(jsonable(value), separators=(",", ":"))


def leaves(value: Any, robot: RobotType | None = None) -> list[Leaf]:
    """``value``'s signals, in a stable order (the order of its fields)."""
    if isinstance(value, Position):
        names = axis_names(value.kind, len(value.axes))
        out = [
            Leaf(name, float(v), axis_unit(value.kind, axis, robot))
            for axis, (name, v) in enumerate(zip(names, value.axes, strict=True), start=1)
        ]
        return [*out, Leaf("arm", _scalar(value.arm))]
    if isinstance(value, FileName):  # a job's name: one text, as the pendant shows it
        return [Leaf("", str(value))]
    if isinstance(value, IOState):
        return [Leaf(str(contact), bool(on)) for contact, on in enumerate(value.contacts)]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out = []
        for f in dataclasses.fields(value):
            inner = getattr(value, f.name)
            if dataclasses.is_dataclass(inner) and not isinstance(inner, type):
                out += [
                    dataclasses.replace(leaf, name=f"{f.name}/{leaf.name}" if leaf.name else f.name)
                    for leaf in leaves(inner, robot)
                ]
            else:
                out.append(Leaf(f.name, _scalar(inner)))
        return out
    return [Leaf("", _scalar(value))]


def channel_of(key: str) -> int | None:
    """The channel a model key belongs to (``ch2/status`` -> 2), or None."""
    head, _, _ = key.partition("/")
    if head.startswith("ch") and head[2:].isdigit():
        return int(head[2:])
    return None


def robot_of(info: Any, key: str) -> RobotType | None:
    """The robot type of the channel ``key`` belongs to, from the controller's AD answer."""
    channel = channel_of(key)
    channels = getattr(info, "channels", ())
    if channel is None or not 1 <= channel <= len(channels):
        return None
    robot = getattr(channels[channel - 1], "robot_type", None)
    return robot if isinstance(robot, RobotType) else None
