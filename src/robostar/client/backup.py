"""Backup and restore of every JOB and PNT file of a controller, with a JSON manifest.

A backup folder holds ``ch<N>/<NAME>.JOB`` and ``ch<N>/<NAME>.PNT`` (one step or point line per
text line, PNT points in angle coordinates in FA's point-line format) and ``manifest.json``:
the controller's AD info, and per file its channel, name, JOB number, size, steps, byte count
and sha256. A restore checks every file against the manifest, uploads them all, then reads each
back with FA and compares.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path

from robostar.client.driver import upload_matches
from robostar.client.exchange import Progress
from robostar.client.files import download_job, download_points, point_lines
from robostar.client.plan import Plan, call
from robostar.commands.files import DownloadFile, ListFiles, UploadFile
from robostar.commands.status import ReadInfo
from robostar.errors import UploadIncompleteError, UsageError
from robostar.protocol.fields import FileName
from robostar.types import ChannelInfo, ControllerInfo, CoordSystem, RobotType

__all__ = ["MANIFEST", "BackupFile", "Manifest", "backup_plan", "restore_plan"]

MANIFEST = "manifest.json"
FORMAT = "robostar-backup"
VERSION = 1


@dataclass(frozen=True, slots=True)
class BackupFile:
    """One file of a backup; ``path`` is relative to the backup folder, with ``/``."""

    channel: int
    name: str
    job_number: int
    size_kb: int
    steps: int
    path: str
    bytes: int
    sha256: str


@dataclass(frozen=True, slots=True)
class Manifest:
    """What a backup holds: when, from which controller, and every file."""

    created: str
    controller: ControllerInfo
    files: tuple[BackupFile, ...]

    def to_json(self) -> str:
        info = self.controller
        data = {
            "format": FORMAT,
            "version": VERSION,
            "created": self.created,
            "controller": {
                "name": info.name,
                "version": info.version,
                "max_channels": info.max_channels,
                "channels": [
                    {
                        "channel": ch.channel,
                        "model": ch.model,
                        "robot_type": ch.robot_type.name,
                        "max_axes": ch.max_axes,
                        "axes_in_use": list(ch.axes_in_use),
                    }
                    for ch in info.channels
                ],
            },
            "files": [asdict(f) for f in self.files],
        }
        return json.dumps(data, indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str) -> Manifest:
        """Read a manifest; UsageError if it is not one this version wrote."""
        try:
            data = json.loads(text)
            if data.get("format") != FORMAT or data.get("version") != VERSION:
                raise ValueError(f"format {data.get('format')!r} version {data.get('version')!r}")
            ctrl = data["controller"]
            channels = tuple(
                ChannelInfo(
                    int(ch["channel"]),
                    str(ch["model"]),
                    RobotType[ch["robot_type"]],
                    int(ch["max_axes"]),
                    tuple(int(a) for a in ch["axes_in_use"]),
                )
                for ch in ctrl["channels"]
            )
            info = ControllerInfo(
                int(ctrl["max_channels"]), str(ctrl["name"]), str(ctrl["version"]), channels
            )
            files = tuple(BackupFile(**f) for f in data["files"])
            return cls(str(data["created"]), info, files)
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise UsageError(
                f"folder: {MANIFEST} is not a robostar backup manifest: {exc}"
            ) from exc


def _folder(folder: object) -> Path:
    if not isinstance(folder, str | os.PathLike):
        raise UsageError(f"folder: must be a path, not {folder!r}")
    return Path(folder)


def _relative(channel: int, name: FileName) -> str:
    return f"ch{channel}/{name}"


def _text(lines: tuple[str, ...]) -> bytes:
    # FA decodes bytes a controller should never send as U+FFFD; they are written as "?".
    return "".join(line + "\n" for line in lines).encode("ascii", "replace")


def _lines(data: bytes) -> tuple[str, ...]:
    text = data.decode("ascii")
    return tuple(text.split("\n")[:-1]) if text else ()


def _report(progress: Progress | None, done: int, total: int) -> None:
    if progress is not None:
        progress(done, total)


def backup_plan(folder: str | os.PathLike[str], progress: Progress | None) -> Plan[Manifest]:
    """Download every file of every defined channel into ``folder``; ``progress`` per file."""
    root = _folder(folder)
    info = yield from call(ReadInfo())
    listing = []
    for channel in info.channels[: info.max_channels]:
        if channel.robot_type is RobotType.NOT_DEFINED:
            continue
        records = yield from call(ListFiles(channel.channel, "*"))
        listing += [(channel.channel, record) for record in records]
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"folder: cannot create {str(root)!r}: {exc}") from exc
    files = []
    for done, (channel_number, record) in enumerate(listing, 1):
        name = FileName.parse(record.name)
        if name.is_job:
            lines = (yield from download_job(channel_number, name, None)).lines
        else:
            points = yield from download_points(channel_number, name, CoordSystem.ANGLE, None)
            lines = point_lines(points)
        data = _text(lines)
        relative = _relative(channel_number, name)
        target = root / relative
        target.parent.mkdir(exist_ok=True)
        target.write_bytes(data)
        digest = hashlib.sha256(data).hexdigest()
        files.append(
            BackupFile(
                channel_number,
                str(name),
                record.job_number,
                record.size_kb,
                record.steps,
                relative,
                len(data),
                digest,
            )
        )
        _report(progress, done, len(listing))
    created = datetime.now(UTC).isoformat(timespec="seconds")
    manifest = Manifest(created, info, tuple(files))
    (root / MANIFEST).write_text(manifest.to_json(), encoding="utf-8")
    return manifest


def _read_backup(root: Path, manifest: Manifest) -> list[UploadFile]:
    """Every file of the backup as its upload, each checked against the manifest first."""
    uploads = []
    for entry in manifest.files:
        name = FileName.parse(entry.name)
        relative = _relative(entry.channel, name)
        try:
            data = (root / relative).read_bytes()
        except OSError as exc:
            raise UsageError(f"folder: cannot read {relative}: {exc}") from exc
        if len(data) != entry.bytes or hashlib.sha256(data).hexdigest() != entry.sha256:
            raise UsageError(f"folder: {relative} does not match its size and sha256 in {MANIFEST}")
        upload = UploadFile(entry.channel, name, entry.job_number, _lines(data))
        upload.encode()  # every line is checked before anything is sent
        uploads.append(upload)
    return uploads


def restore_plan(folder: str | os.PathLike[str], progress: Progress | None) -> Plan[Manifest]:
    """Upload a backup, then read every file back and compare.

    ``progress(done, total)`` counts uploads then read-backs (total: twice the files).
    """
    root = _folder(folder)
    try:
        text = (root / MANIFEST).read_text(encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"folder: cannot read {MANIFEST}: {exc}") from exc
    manifest = Manifest.from_json(text)
    uploads = _read_backup(root, manifest)
    total = 2 * len(uploads)
    for done, upload in enumerate(uploads, 1):
        yield from call(upload)
        _report(progress, done, total)
    for done, upload in enumerate(uploads, len(uploads) + 1):
        content = yield from call(DownloadFile(upload.channel, upload.file, CoordSystem.ANGLE))
        if not upload_matches(upload, content):
            raise UploadIncompleteError(
                f"restore: {_relative(upload.channel, FileName.parse(str(upload.file)))} read back"
                " from the controller differs from the backup"
            )
        _report(progress, done, total)
    return manifest
