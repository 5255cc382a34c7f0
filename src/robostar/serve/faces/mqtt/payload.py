"""Payloads: JSON with the value, its time and its quality; and report-by-exception rules."""

from __future__ import annotations

import json
from typing import Any

from robostar.serve.jsonable import jsonable
from robostar.serve.model import Sample

__all__ = ["encode", "within_deadband"]


def encode(sample: Sample, *, historical: bool = False) -> bytes:
    """``{"value": ..., "ts": <unix seconds>, "quality": "good"|"stale"|"line down"}``, with
    ``"historical": true`` for a change replayed from the store-and-forward buffer."""
    body: dict[str, Any] = {
        "value": jsonable(sample.value),
        "ts": round(sample.at, 3),
        "quality": sample.quality.value,
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
