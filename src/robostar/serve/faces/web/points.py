"""Writing one point of a PNT file: the one code path of the point editor and of "teach here".

The file is read fresh from the controller (angle data), the point set, and the whole file
written back with FB under the JOB number it has (a new file: 0), through the line (lease and
audit). A file that does not exist yet starts empty.
"""

from __future__ import annotations

from dataclasses import dataclass

from robostar.client.files import point_lines
from robostar.commands.files import DownloadFile, FileExists, ListFiles, UploadFile
from robostar.protocol.fields import FileName
from robostar.serve.faces.web.auth import Account
from robostar.serve.faces.web.deps import Forbidden, WebDeps
from robostar.serve.lease import Who
from robostar.serve.line import Line
from robostar.serve.programs import program_text, text_of_lines
from robostar.types import ArmForm, CoordSystem, JobFile, Point, PointFile

__all__ = [
    "PointChange",
    "axes_of",
    "describe_change",
    "keep_download",
    "read_points",
    "write_point",
]


@dataclass(frozen=True, slots=True)
class PointChange:
    """What a point write changed: the file, the point, its old value (None: new), its new."""

    channel: int
    name: FileName
    number: int
    old: Point | None
    new: Point


def axes_of(content: PointFile) -> int:
    """How many axes a new point of this file has: as many as its other points."""
    return max((len(p.axes) for p in content.points.values()), default=4)


async def read_points(line: Line, channel: int, name: FileName) -> PointFile:
    """The file's points as the controller holds them now (an empty table if it has none)."""
    if not name.is_points:
        raise Forbidden(400, f"{name} is not a point file")
    if not await line.read(FileExists(channel, name), max_age=0):
        return PointFile({})
    content = await line.read(DownloadFile(channel, name, CoordSystem.ANGLE), max_age=0)
    if not isinstance(content, PointFile):
        raise Forbidden(400, f"{name} did not download as a point table")
    return content


def keep_download(
    deps: WebDeps, line: Line, channel: int, name: FileName, content: object, who: Who
) -> None:
    """Keep a file downloaded in joint angles as a version (XY data is not the file's text)."""
    if isinstance(content, JobFile | PointFile):
        deps.keep(line, channel, name, program_text(content), who, "download")


async def write_point(
    deps: WebDeps,
    line: Line,
    account: Account,
    channel: int,
    name: FileName,
    number: int,
    axes: tuple[float, ...],
    content: PointFile | None = None,
    arm: ArmForm | None = None,
    why: str = "point edit",
) -> PointChange:
    """Set point ``number`` of ``name`` to ``axes`` (angles) and write the file back; the arm
    form is ``arm``, else the old point's."""
    if content is None:
        content = await read_points(line, channel, name)
    old = content.points.get(number)
    if arm is None:
        arm = old.arm if old is not None else ArmForm.NONE
    new = Point(axes, arm, True)
    points = {**content.points, number: new}
    records = await line.read(ListFiles(channel, "*"), max_age=0)
    job_number = next((r.job_number for r in records if r.name == str(name)), 0)
    lines = point_lines(points)
    await deps.run(line, UploadFile(channel, name, job_number, lines), account)
    change = PointChange(channel, name, number, old, new)
    who = Who(account.name, "web")
    line.record(describe_change(change, why), who, "ok")
    deps.keep(line, channel, name, text_of_lines(lines), who, why)
    return change


def _axes_text(point: Point) -> str:
    return "(" + ", ".join(f"{value:.3f}" for value in point.axes) + ")"


def describe_change(change: PointChange, why: str) -> str:
    """The audit's words for a point write: which point, from what to what."""
    where = f"point {change.number} of {change.name} on channel {change.channel}"
    if change.old is None:
        return f"{why}: {where} set to {_axes_text(change.new)} (a new point)"
    return f"{why}: {where} changed from {_axes_text(change.old)} to {_axes_text(change.new)}"
