"""Payloads: JSON with the value, its time and its quality; and report-by-exception rules."""

from __future__ import annotations

import json
from typing import Any

from robostar.serve.faces.mqtt.leaves import leaves
from robostar.serve.jsonable import jsonable
from robostar.serve.model import Sample
from robostar.types import Position, RobotType

__all__ = ["OFFLINE", "encode", "named_axes", "within_deadband"]

OFFLINE = "offline"
"""The quality the retained values say after a clean stop: no one vouches for them any more."""


def named_axes(position: Position, robot: RobotType | None = None) -> dict[str, Any]:
    """A position as named values with units: ``{"x": {"value": 250.0, "unit": "mm"}, ...,
    "arm": "right"}`` (joint angles ``j1``.., pulses ``p1``..)."""
    out: dict[str, Any] = {}
    for leaf in leaves(position, robot):
        unit = leaf.unit
        out[leaf.name] = leaf.value if unit is None else {"value": leaf.value, "unit": unit}
    return out


def encode(
    sample: Sample,
    *,
    historical: bool = False,
    robot: RobotType | None = None,
    quality: str | None = None,
) -> bytes:
    """``{"value": ..., "ts": <unix seconds>, "quality": "good"|"stale"|"line down"}``, with
    ``"historical": true`` for a change replayed from the store-and-forward buffer. A position's
    axes are named, with units (:func:`named_axes`, ``robot`` the channel's robot type);
    ``quality`` says another quality than the sample's (``offline``)."""
    value = sample.value
    body: dict[str, Any] = {
        "value": named_axes(value, robot) if isinstance(value, Position) else jsonable(value),
        "ts": round(sample.at, 3),
        "quality": quality or sample.quality.value,
    }
    if historical:
        body["historical"] = True
    return json.dumps(body, separators=(",", ":")).encode()


def _numbers(value: Any) -> list[float] | None:
    """The numbers a position-like value holds (its axes), or None for anything else."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int | float):
        return [float(value)]
    axes = getattr(value, "axes", None)
    if isinstance(axes, tuple) and all(isinstance(a, int | float) for a in axes):
        return [float(a) for a in axes]
    return None


def within_deadband(old: Any, new: Any, deadband: float) -> bool:
    """True when ``new`` differs from ``old`` by less than ``deadband`` on every axis (and in
    nothing else): not worth a message. Non-numeric values always count when they change."""
    if deadband <= 0:
        return bool(old == new)
    a, b = _numbers(old), _numbers(new)
    if a is None or b is None or len(a) != len(b):
        return bool(old == new)
    same_rest = getattr(old, "kind", None) == getattr(new, "kind", None) and getattr(
        old, "arm", None
    ) == getattr(new, "arm", None)
    return bool(same_rest) and all(abs(x - y) < deadband for x, y in zip(a, b, strict=True))
