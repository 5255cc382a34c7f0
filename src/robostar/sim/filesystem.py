"""A channel's files: JOB files (job number + lines) and PNT files (numbered points).

Names are looked up case-folded (``RS.JOB`` and ``rs.job`` are one file) and kept as they were
written. Point values are joint values (degrees, or mm on a linear axis) with the arm form.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from robostar.commands.files import format_point_line
from robostar.protocol.fields import FileName
from robostar.sim.config import ChannelConfig
from robostar.sim.kinematics import arm_of
from robostar.types import ArmForm, FileRecord, Point, RobotType

__all__ = ["ChannelFiles", "StoredFile", "StoredJob", "StoredPoints", "default_files"]

DEMO = "DEMO"


@dataclass
class StoredJob:
    name: FileName
    number: int
    lines: list[str]

    @property
    def size(self) -> int:
        return sum(len(line) + 1 for line in self.lines)

    @property
    def steps(self) -> int:
        return len(self.lines)


@dataclass
class StoredPoints:
    name: FileName
    points: dict[int, Point] = field(default_factory=dict)

    @property
    def size(self) -> int:
        return sum(len(format_point_line(n, p)) + 1 for n, p in self.points.items())

    @property
    def steps(self) -> int:
        return len(self.points)


StoredFile = StoredJob | StoredPoints


class ChannelFiles:
    """The files of one channel."""

    def __init__(self) -> None:
        self._files: dict[str, StoredFile] = {}

    def get(self, name: FileName) -> StoredFile | None:
        return self._files.get(name.key)

    def put(self, stored: StoredFile) -> None:
        self._files[stored.name.key] = stored

    def remove(self, name: FileName) -> None:
        del self._files[name.key]

    def __iter__(self) -> Iterator[StoredFile]:
        return iter(sorted(self._files.values(), key=lambda f: f.name.key))

    def job_number(self, stem: str) -> int:
        """The job number of the JOB file with this stem (0 if none): FD shows it for its PNT."""
        job = self._files.get(f"{stem}.JOB".upper())
        return job.number if isinstance(job, StoredJob) else 0

    def free_job_number(self) -> int:
        used = {f.number for f in self._files.values() if isinstance(f, StoredJob)}
        return next((n for n in range(1, 201) if n not in used), 0)

    def record(self, stored: StoredFile) -> FileRecord:
        number = (
            stored.number if isinstance(stored, StoredJob) else self.job_number(stored.name.stem)
        )
        return FileRecord(number, str(stored.name), math.ceil(stored.size / 1024), stored.steps)

    # -- persistence ---------------------------------------------------------------------------
    def to_json(self) -> list[dict[str, Any]]:
        out: list[dict[str, Any]] = []
        for stored in self:
            if isinstance(stored, StoredJob):
                out.append(
                    {"name": str(stored.name), "number": stored.number, "lines": stored.lines}
                )
            else:
                points = [
                    [n, list(p.axes), int(p.arm), p.used] for n, p in sorted(stored.points.items())
                ]
                out.append({"name": str(stored.name), "points": points})
        return out

    @classmethod
    def from_json(cls, data: list[dict[str, Any]]) -> ChannelFiles:
        files = cls()
        for item in data:
            name = FileName.parse(str(item["name"]))
            if name.is_job:
                files.put(StoredJob(name, int(item["number"]), [str(x) for x in item["lines"]]))
            else:
                points = {
                    int(n): Point(tuple(float(v) for v in axes), ArmForm(int(arm)), bool(used))
                    for n, axes, arm, used in item["points"]
                }
                files.put(StoredPoints(name, points))
        return files


def _demo_points(cfg: ChannelConfig) -> dict[int, tuple[float, ...]]:
    """Three points inside the limits; on a SCARA all in the right-arm form, so LMOV works."""
    base: dict[int, tuple[float, ...]]
    if cfg.robot is RobotType.SCARA:
        base = {
            1: (30.0, 60.0, 50.0, 0.0),
            2: (0.0, 60.0, 50.0, 0.0),
            3: (-30.0, 90.0, 100.0, 45.0),
        }
    else:
        base = {1: (100.0, 100.0, 50.0), 2: (300.0, 200.0, 50.0), 3: (500.0, 400.0, 100.0)}
    out = {}
    for number, values in base.items():
        axes = []
        for axis in range(cfg.axes):
            lo, hi = cfg.limits[axis]
            value = values[axis] if axis < len(values) else 0.0
            axes.append(min(max(value, lo), hi))
        out[number] = tuple(axes)
    return out


DEMO_JOB = (
    "MAIN",
    "JMOV P1",
    "LMOV P2",
    "OUT 0,0,1",
    "DELAY 200",
    "JMOV P3",
    "OUT 0,0,0",
    "EOP",
)


def default_files(cfg: ChannelConfig) -> ChannelFiles:
    """A demo JOB (number 1) and its PNT file, as a fresh simulator has them."""
    files = ChannelFiles()
    lines = DEMO_JOB if cfg.can_move else [line for line in DEMO_JOB if "MOV" not in line]
    files.put(StoredJob(FileName(DEMO, "JOB"), 1, list(lines)))
    points = {n: Point(v, arm_of(cfg, v), True) for n, v in _demo_points(cfg).items()}
    files.put(StoredPoints(FileName(DEMO, "PNT"), points))
    return files
