"""The XY view's workspace: where a channel's tool can go, from the controller's parameters.

KE index 3 (RANG) gives each axis's soft limits and index 2 (LENG) a SCARA's two link lengths.
A SCARA's workspace is drawn as the curves that bound it: the image, through its forward
kinematics, of the border of its joint 1 x joint 2 range, and the outer arc of the stretched arm
(joint 2 at 0) when joint 2 may pass 0; a cartesian robot's is the rectangle of its axis 1 and 2
limits. The parameter texts are parsed leniently (``lo~hi``
pairs, numbers): a controller that answers otherwise gets a view without a workspace, scaled to
what it shows, and the page says so.
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass

from robostar.commands.system import ReadParameters
from robostar.errors import RobostarError
from robostar.serve.faces.web.views import robot_of
from robostar.serve.line import Line
from robostar.types import RobotType

__all__ = ["Cache", "Workspace", "read_workspace", "scara_outline"]

RANG = 3
LENG = 2
KEEP = 60.0
"""Seconds a channel's workspace is reused before its parameters are read again."""
_EDGE_SAMPLES = 40
_RANGE = re.compile(r"(-?\d+(?:\.\d+)?)\s*~\s*(-?\d+(?:\.\d+)?)")
_NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


@dataclass(frozen=True, slots=True)
class Workspace:
    """The curves that bound it (each a polyline of XY points, mm) and its bounding box
    (xmin, ymin, xmax, ymax)."""

    outlines: tuple[tuple[tuple[float, float], ...], ...]
    box: tuple[float, float, float, float]


Polyline = tuple[tuple[float, float], ...]


def scara_outline(
    links: tuple[float, float], j1: tuple[float, float], j2: tuple[float, float]
) -> tuple[Polyline, ...]:
    """The border of the joint rectangle ``j1`` x ``j2`` (degrees) mapped to XY, and the arc of
    the stretched arm if joint 2 may pass 0 (the farthest reach, inside the rectangle)."""
    l1, l2 = links

    def xy(a: float, b: float) -> tuple[float, float]:
        r1, r12 = math.radians(a), math.radians(a + b)
        return (
            round(l1 * math.cos(r1) + l2 * math.cos(r12), 2),
            round(l1 * math.sin(r1) + l2 * math.sin(r12), 2),
        )

    def between(lo: float, hi: float) -> list[float]:
        return [lo + (hi - lo) * i / _EDGE_SAMPLES for i in range(_EDGE_SAMPLES)]

    edge = [xy(a, j2[0]) for a in between(*j1)]
    edge += [xy(j1[1], b) for b in between(*j2)]
    edge += [xy(a, j2[1]) for a in between(j1[1], j1[0])]
    edge += [xy(j1[0], b) for b in between(j2[1], j2[0])]
    curves: list[Polyline] = [(*edge, edge[0])]
    if j2[0] < 0 < j2[1]:
        arc = [xy(a, 0.0) for a in between(*j1)]
        curves.append((*arc, xy(j1[1], 0.0)))
    return tuple(curves)


def _box(outlines: tuple[Polyline, ...]) -> tuple[float, float, float, float]:
    xs = [p[0] for curve in outlines for p in curve]
    ys = [p[1] for curve in outlines for p in curve]
    return (min(xs), min(ys), max(xs), max(ys))


def parse_ranges(text: str) -> list[tuple[float, float]]:
    return [(float(lo), float(hi)) for lo, hi in _RANGE.findall(text)]


def parse_links(text: str) -> tuple[float, float] | None:
    numbers = [float(n) for n in _NUMBER.findall(text.partition(":")[2] or text)]
    if len(numbers) >= 2 and numbers[0] > 0 and numbers[1] > 0:
        return numbers[0], numbers[1]
    return None


Cache = dict[tuple[str, int], tuple[float, "Workspace | None"]]


async def read_workspace(line: Line, channel: int, cache: Cache) -> Workspace | None:
    """The channel's workspace (reused from ``cache`` for :data:`KEEP` s), or None if it
    cannot be told."""
    key = (line.name, channel)
    now = time.monotonic()
    cached = cache.get(key)
    if cached is not None and now - cached[0] < KEEP:
        return cached[1]
    found = await _read(line, channel)
    cache[key] = (now, found)
    return found


async def _read(line: Line, channel: int) -> Workspace | None:
    robot = robot_of(line, channel)
    try:
        rang: tuple[str, ...] = await line.read(ReadParameters(channel, RANG))
        ranges = parse_ranges(" ".join(rang))
        if len(ranges) < 2:
            return None
        if robot is RobotType.SCARA:
            leng: tuple[str, ...] = await line.read(ReadParameters(channel, LENG))
            links = parse_links(" ".join(leng))
            if links is None:
                return None
            outlines = scara_outline(links, ranges[0], ranges[1])
        else:
            (x0, x1), (y0, y1) = ranges[0], ranges[1]
            outlines = (((x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)),)
    except RobostarError:
        return None
    return Workspace(outlines, _box(outlines))
