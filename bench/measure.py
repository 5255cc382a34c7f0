"""Shared measuring helpers: medians and percentiles, result rows, the printed table."""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

__all__ = ["BAUD", "Row", "format_table", "median", "percentile", "wire_seconds"]

BAUD = 115200
"""The N1's default line speed; every wire time below is at this rate."""
BITS_PER_BYTE = 10
"""8N1: start bit, 8 data bits, stop bit."""


def wire_seconds(nbytes: int, baud: int = BAUD) -> float:
    """Time ``nbytes`` take on an 8N1 serial line."""
    return nbytes * BITS_PER_BYTE / baud


def median(values: Iterable[float]) -> float:
    items = list(values)
    return statistics.median(items) if items else math.nan


def percentile(values: Sequence[float], q: float) -> float:
    """Nearest-rank percentile (``q`` in 0..100); NaN for no values."""
    if not values:
        return math.nan
    ordered = sorted(values)
    rank = max(1, math.ceil(q / 100 * len(ordered)))
    return ordered[min(rank, len(ordered)) - 1]


@dataclass(frozen=True, slots=True)
class Row:
    """One line of the summary table: a figure, its target, and whether the target is met
    (``None`` where there is no target: reference figures)."""

    item: str
    name: str
    value: str
    target: str = ""
    met: bool | None = None

    def as_dict(self) -> dict[str, object]:
        return {
            "item": self.item,
            "name": self.name,
            "value": self.value,
            "target": self.target,
            "met": self.met,
        }


def _verdict(met: bool | None) -> str:
    return "" if met is None else ("met" if met else "MISSED")


def format_table(rows: Sequence[Row], *, markdown: bool = False) -> str:
    """The rows as an aligned text table, or as a Markdown table."""
    header = ("item", "measure", "value", "target", "")
    cells = [header, *((r.item, r.name, r.value, r.target, _verdict(r.met)) for r in rows)]
    if markdown:
        lines = ["| " + " | ".join(header[:4]) + " | verdict |", "|---|---|---:|---|---|"]
        lines += ["| " + " | ".join(c) + " |" for c in cells[1:]]
        return "\n".join(lines)
    widths = [max(len(c[i]) for c in cells) for i in range(len(header))]
    out = []
    for n, c in enumerate(cells):
        out.append("  ".join(text.ljust(w) for text, w in zip(c, widths, strict=True)).rstrip())
        if n == 0:
            out.append("  ".join("-" * w for w in widths))
    return "\n".join(out)
