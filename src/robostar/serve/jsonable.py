"""Model values as JSON: robostar's dataclasses, enums and tuples to plain JSON types."""

from __future__ import annotations

import dataclasses
import enum
from typing import Any

from robostar.serve.model import Sample

__all__ = ["jsonable", "sample_json"]


def jsonable(value: Any) -> Any:
    """A JSON-ready copy of ``value`` (dataclasses become objects, enums their names)."""
    if isinstance(value, enum.Enum):
        return value.name.lower()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [jsonable(v) for v in value]
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return str(value)


def sample_json(sample: Sample) -> dict[str, Any]:
    return {
        "value": jsonable(sample.value),
        "at": sample.at,
        "age": round(sample.age, 3),
        "quality": sample.quality.value,
    }
