"""File operations: FA download, FB upload, FC, FD, FE delete, FF copy, FG rename."""

from __future__ import annotations

from robostar.commands.files import ListFiles
from robostar.protocol.fields import FileName
from robostar.sim.alarms import AlarmCode
from robostar.sim.filesystem import StoredJob, StoredPoints
from robostar.sim.kinematics import to_xy
from robostar.sim.state import (
    Channel,
    ModelBase,
    Refused,
)
from robostar.types import (
    CoordSystem,
    FileRecord,
    JobFile,
    Point,
    PointFile,
)

__all__ = ["FileOps"]

MAX_FILES = ListFiles.MAX_PACKETS - 1
"""Files a channel holds at most: what one FD answer lists (a packet per file, then END)."""


class FileOps(ModelBase):
    """FA-FG on a channel's JOB and PNT files."""

    # -- files ---------------------------------------------------------------------------------
    def _file(self, ch: Channel, name: FileName) -> StoredJob | StoredPoints:
        stored = ch.files.get(name)
        if stored is None:
            raise Refused(f"no file {name} on channel {ch.number}")
        return stored

    def _in_use(self, ch: Channel, name: FileName) -> bool:
        return (
            ch.job is not None
            and ch.job.running
            and ch.job_name is not None
            and ch.job_name.key == name.key
        )

    def download(self, number: int, name: FileName, coords: CoordSystem) -> JobFile | PointFile:
        ch = self.channel(number)
        stored = self._file(ch, name)
        if isinstance(stored, StoredJob):
            return JobFile(tuple(stored.lines))
        points = {}
        for n, point in stored.points.items():
            if coords is CoordSystem.XY:
                axes = point.axes[: ch.cfg.axes]
                xy = to_xy(ch.cfg, axes) if len(axes) == ch.cfg.axes else axes
                point = Point(xy + point.axes[len(xy) :], point.arm, point.used)
            points[n] = point
        return PointFile(points)

    def exists(self, number: int, name: FileName) -> bool:
        return self.channel(number).files.get(name) is not None

    def list_files(self, number: int, pattern: str) -> tuple[FileRecord, ...]:
        ch = self.channel(number)
        if pattern in ("*", "*.*"):
            return tuple(ch.files.record(f) for f in ch.files)
        stored = ch.files.get(FileName.parse(pattern))
        return (ch.files.record(stored),) if stored is not None else ()

    def delete(self, number: int, name: FileName) -> None:
        ch = self.channel(number)
        if name.is_points:
            raise Refused("PNT files cannot be deleted (the manual: planned); only JOB files")
        self._file(ch, name)
        if self._in_use(ch, name):
            raise Refused(f"{name} is the running job of channel {ch.number}")
        ch.files.remove(name)
        if ch.job_name is not None and ch.job_name.key == name.key:
            ch.job = None
            ch.job_name = None
        self.changed()

    def copy(self, number: int, name: FileName, to_number: int, to_name: FileName) -> None:
        ch = self.channel(number)
        if to_number != number:
            raise self._alarm_refusal(
                AlarmCode.RUN_FAIL,
                ch,
                f"FF copies within one channel only (channel {number} to {to_number})",
                "FF channel",
            )
        stored = ch.files.get(name)
        if stored is None:
            raise self._alarm_refusal(
                AlarmCode.RUN_FAIL, ch, f"no file {name} on channel {ch.number}", f"FF {name}"
            )
        if name.extension.upper() != to_name.extension.upper():
            raise Refused(f"{name} and {to_name} are not the same kind of file")
        if ch.files.get(to_name) is not None:
            raise Refused(f"{to_name} already exists on channel {ch.number}")
        if isinstance(stored, StoredJob):
            ch.files.put(StoredJob(to_name, ch.files.free_job_number(), list(stored.lines)))
        else:
            ch.files.put(StoredPoints(to_name, dict(stored.points)))
        self.changed()

    def rename(self, number: int, name: FileName, new_name: FileName) -> None:
        ch = self.channel(number)
        stored = ch.files.get(name)
        if stored is None:
            raise self._alarm_refusal(
                AlarmCode.RUN_FAIL, ch, f"no file {name} on channel {ch.number}", f"FG {name}"
            )
        if name.extension.upper() != new_name.extension.upper():
            raise Refused(f"{name} and {new_name} are not the same kind of file")
        if name.key != new_name.key and ch.files.get(new_name) is not None:
            raise Refused(f"{new_name} already exists on channel {ch.number}")
        if self._in_use(ch, name):
            raise Refused(f"{name} is the running job of channel {ch.number}")
        ch.files.remove(name)
        stored.name = new_name
        ch.files.put(stored)
        if ch.job_name is not None and ch.job_name.key == name.key:
            ch.job_name = new_name
        self.changed()

    def check_upload(self, number: int, name: FileName, job_number: int) -> None:
        """FB's first packet: may this file be written?"""
        ch = self.channel(number)
        if self._in_use(ch, name):
            raise Refused(f"{name} is the running job of channel {ch.number}")
        stored = ch.files.get(name)
        if stored is None and sum(1 for _ in ch.files) >= MAX_FILES:
            # A directory FD can list whole: a JOB and a PNT file per JOB number (0-200).
            raise Refused(f"channel {ch.number} holds {MAX_FILES} files, its most")
        if isinstance(stored, StoredJob) and stored.number != job_number:
            raise self._alarm_refusal(
                AlarmCode.JOB_NUMBER,
                ch,
                f"{stored.name} has job number {stored.number}, not {job_number}",
                f"FB {name.stem} {job_number}",
            )

    def store_upload(
        self,
        number: int,
        name: FileName,
        job_number: int,
        lines: list[str],
        points: dict[int, Point],
    ) -> None:
        """FB's closing packet: write the file."""
        ch = self.channel(number)
        if name.is_job:
            ch.files.put(StoredJob(name, job_number, list(lines)))
        else:
            ch.files.put(StoredPoints(name, dict(points)))
        self.changed()
