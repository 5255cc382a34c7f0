"""Checks and conversions of the client's arguments, each error naming the argument.

The command classes check every field again when they encode; these checks come first so that
friendly spellings (``kind="xy"``, ``direction="+"``) work and mistakes name the argument as the
caller wrote it.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping, Sequence
from typing import TypeVar

from robostar.errors import FieldError, UsageError
from robostar.protocol.fields import check_channel, encode_coord
from robostar.types import CoordSystem, JogDirection, MotionType, PositionKind

__all__ = [
    "MAX_SECONDS",
    "axes",
    "boolean",
    "channel",
    "coord_system",
    "jog_direction",
    "motion_type",
    "non_negative_int",
    "position_kind",
    "positive",
]

_E = TypeVar("_E", bound=enum.Enum)

_POSITION_KINDS = {"xy": PositionKind.XY, "pulse": PositionKind.PULSE, "angle": PositionKind.ANGLE}
_COORDS = {"angle": CoordSystem.ANGLE, "xy": CoordSystem.XY}
_MOTIONS = {
    "joint": MotionType.JOINT,
    "jmov": MotionType.JOINT,
    "linear": MotionType.LINEAR,
    "lmov": MotionType.LINEAR,
    "arc": MotionType.ARC,
    "amov": MotionType.ARC,
    "circle": MotionType.CIRCLE,
    "cmov": MotionType.CIRCLE,
}
_DIRECTIONS = {
    "+": JogDirection.PLUS,
    "plus": JogDirection.PLUS,
    "-": JogDirection.MINUS,
    "minus": JogDirection.MINUS,
}


def _choice(name: str, value: object, kind: type[_E], names: Mapping[str, _E]) -> _E:
    if isinstance(value, kind):
        return value
    if isinstance(value, str) and value.strip().lower() in names:
        return names[value.strip().lower()]
    allowed = ", ".join(repr(n) for n in names)
    raise UsageError(f"{name}: {value!r} is not one of {allowed} (or a {kind.__name__})")


def position_kind(value: object) -> PositionKind:
    return _choice("kind", value, PositionKind, _POSITION_KINDS)


def coord_system(value: object, name: str = "coords") -> CoordSystem:
    return _choice(name, value, CoordSystem, _COORDS)


def motion_type(value: object, name: str = "motion") -> MotionType:
    return _choice(name, value, MotionType, _MOTIONS)


def jog_direction(value: object) -> JogDirection:
    if isinstance(value, int) and not isinstance(value, bool | JogDirection) and value in (1, -1):
        return JogDirection.PLUS if value > 0 else JogDirection.MINUS
    return _choice("direction", value, JogDirection, _DIRECTIONS)


def channel(value: object, name: str = "channel") -> int:
    """A pendant channel number, 1-3."""
    return check_channel("", value, name)  # type: ignore[arg-type]  # checked inside


def boolean(value: object, name: str) -> bool:
    if not isinstance(value, bool):
        raise UsageError(f"{name}: must be True or False, not {value!r}")
    return value


MAX_SECONDS = 1_000_000.0
"""The longest timeout or interval taken (11 days): the clock's waits overflow near 1e10 s."""


def positive(value: object, name: str) -> float:
    """A finite number of seconds above zero and at most ``MAX_SECONDS`` (a timeout, an
    interval)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
        raise UsageError(f"{name}: must be a number above 0, not {value!r}")
    if not math.isfinite(value):
        raise UsageError(f"{name}: must be finite, not {value!r}")
    if value > MAX_SECONDS:
        raise UsageError(f"{name}: must be at most {MAX_SECONDS:.0f} seconds, not {value!r}")
    return float(value)


def non_negative_int(value: object, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise UsageError(f"{name}: must be a whole number 0 or more, not {value!r}")
    return value


def axes(value: object, name: str) -> tuple[float, ...]:
    """1 to 6 axis values, each finite and fitting the wire's 10 bytes with 3 decimals."""
    if isinstance(value, str | bytes) or not isinstance(value, Sequence):
        raise UsageError(f"{name}: must be a sequence of 1-6 axis values, not {value!r}")
    if not 1 <= len(value) <= 6:
        raise FieldError("", name, f"has {len(value)} axis values; 1-6 are allowed")
    for i, item in enumerate(value, 1):
        # The wire's own check (finite, fits 10 bytes with 3 decimals), named as the caller
        # wrote the argument.
        encode_coord("", f"{name} axis {i}", item, exact=True)
    return tuple(float(item) for item in value)
