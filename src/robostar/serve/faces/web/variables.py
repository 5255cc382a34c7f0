"""The global variables page: what to read for a range of indexes, and a checked write.

Kept apart from ``app.py`` so the rules (ranges, widths, the resolution of a float) live in one
place; the handlers in ``app.py`` add the role, the CSRF check, the confirmation and the lease.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from robostar.commands.base import Command
from robostar.commands.variables import (
    MAX_POINT_INDEX,
    MAX_VALUE_INDEX,
    ReadGlobalFloat,
    ReadGlobalInt,
    ReadGlobalPoint,
    WriteGlobalFloat,
    WriteGlobalInt,
)
from robostar.errors import RobostarError, UsageError
from robostar.serve.line import Line

__all__ = ["KINDS", "PAGE_MAX", "VariableRow", "build_write", "read_rows"]

KINDS = ("int", "float", "point")
PAGE_MAX = 50
"""Indexes read for one page: each is one exchange on the line, so a page stays short."""
INT_LOW, INT_HIGH = -99999, 999999
FLOAT_LIMIT = 1e6


@dataclass(frozen=True, slots=True)
class VariableRow:
    index: int
    value: Any = None
    error: str | None = None


def last_index(kind: str) -> int:
    return MAX_POINT_INDEX if kind == "point" else MAX_VALUE_INDEX


def check_kind(kind: str) -> str:
    if kind not in KINDS:
        raise UsageError(f"kind: one of {', '.join(KINDS)}, not {kind!r}")
    return kind


def page_range(kind: str, start: int, count: int) -> range:
    """The indexes of a page, clipped to what the controller holds and to PAGE_MAX."""
    top = last_index(kind)
    if not 0 <= start <= top:
        raise UsageError(f"start: {start} is not in 0-{top}")
    count = max(1, min(count, PAGE_MAX))
    return range(start, min(top, start + count - 1) + 1)


def _read_command(kind: str, channel: int, index: int) -> Command[Any]:
    if kind == "int":
        return ReadGlobalInt(index)
    if kind == "float":
        return ReadGlobalFloat(index)
    return ReadGlobalPoint(channel, index)


async def read_rows(line: Line, kind: str, channel: int, indexes: range) -> list[VariableRow]:
    """Read each index fresh (max_age 0: a page must show what the controller holds now)."""
    rows = []
    for index in indexes:
        try:
            value = await line.read(_read_command(kind, channel, index), max_age=0)
        except RobostarError as exc:
            rows.append(VariableRow(index, error=str(exc)))
            if not line.health.up:
                break  # the line is down: one error says it, not fifty
            continue
        rows.append(VariableRow(index, value))
    return rows


def build_write(kind: str, index: int, text: str) -> Command[Any]:
    """The GW command for a form's value, or UsageError naming the rule it breaks."""
    if kind == "point":
        raise UsageError("global points are shown, not written here (use the point editor)")
    if not 0 <= index <= MAX_VALUE_INDEX:
        raise UsageError(f"index: {index} is not in 0-{MAX_VALUE_INDEX}")
    text = text.strip()
    if kind == "int":
        try:
            number = int(text)
        except ValueError:
            raise UsageError(f"value: a whole number, not {text!r}") from None
        if not INT_LOW <= number <= INT_HIGH:
            raise UsageError(f"value: {number} is not in {INT_LOW}-{INT_HIGH}")
        return WriteGlobalInt(index, number)
    try:
        real = float(text)
    except ValueError:
        raise UsageError(f"value: a number, not {text!r}") from None
    if not math.isfinite(real) or abs(real) >= FLOAT_LIMIT:
        raise UsageError(f"value: {text!r} does not fit the controller's float")
    if round(real, 3) != real:
        raise UsageError(f"value: at most 3 decimals ({text!r})")
    return WriteGlobalFloat(index, real)
