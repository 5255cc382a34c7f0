"""The manifest format: what a backup folder holds, as ``manifest.json``.

A backup folder holds ``ch<N>/<NAME>.JOB`` and ``ch<N>/<NAME>.PNT`` (one step or point line
per text line, PNT points in angle coordinates in FA's point-line format) and
``manifest.json``: the controller's AD info, and per file its channel, name, JOB number,
size, steps, byte count and sha256. Nothing here touches a file: the store reads and writes
them.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from datetime import datetime

from robostar.client.files import NAME_RULE
from robostar.errors import UsageError
from robostar.protocol.fields import FileName
from robostar.types import ChannelInfo, ControllerInfo, RobotType

__all__ = [
    "FORMAT",
    "MANIFEST",
    "VERSION",
    "BackupFile",
    "Manifest",
    "created_time",
    "file_bytes",
    "file_lines",
    "is_manifest",
    "relative_path",
    "validate_manifest",
]

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
    """What a backup holds: when, from which controller, and every file.

    ``target`` is the URL the backup was read from and ``simulator`` whether that was a
    simulator (None in a manifest written before they were recorded, or when it is not
    known). ``folder`` is where this backup is on disk (set by backup and restore, not
    written to the manifest).
    """

    created: str
    controller: ControllerInfo
    files: tuple[BackupFile, ...]
    target: str | None = None
    simulator: bool | None = None
    folder: str | None = field(default=None, compare=False)

    def to_json(self) -> str:
        info = self.controller
        data = {
            "format": FORMAT,
            "version": VERSION,
            "created": self.created,
            "target": self.target,
            "simulator": self.simulator,
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
            # Manifests written before target and simulator were recorded have neither.
            target = data.get("target")
            simulator = data.get("simulator")
            if target is not None and not isinstance(target, str):
                raise ValueError(f"target {target!r} is not text")
            if simulator is not None and not isinstance(simulator, bool):
                raise ValueError(f"simulator {simulator!r} is not true or false")
            return cls(str(data["created"]), info, files, target, simulator)
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise UsageError(
                f"folder: {MANIFEST} is not a robostar backup manifest: {exc}"
            ) from exc


def is_manifest(text: str) -> bool:
    """Is ``text`` a manifest of this module's format (any version)?"""
    try:
        data = json.loads(text)
    except ValueError:
        return False
    return isinstance(data, dict) and data.get("format") == FORMAT


def created_time(text: str) -> float | None:
    """The ``created`` time of a manifest's text, as a POSIX timestamp (None if it has none)."""
    try:
        data = json.loads(text)
        return datetime.fromisoformat(str(data["created"])).timestamp()
    except (ValueError, KeyError, TypeError):
        return None


def relative_path(channel: int, name: FileName) -> str:
    """Where a controller file goes in a backup folder (and how restores name it)."""
    return f"ch{channel}/{name}"


def file_bytes(lines: tuple[str, ...]) -> bytes:
    """A file's lines as a backup holds them: one per text line."""
    # Job lines outside ASCII are refused by download_job; points are formatted as ASCII.
    return "".join(line + "\n" for line in lines).encode("ascii")


def file_lines(data: bytes) -> tuple[str, ...]:
    """The lines of a file of a backup (UnicodeDecodeError if it is not ASCII)."""
    text = data.decode("ascii")
    return tuple(text.split("\n")[:-1]) if text else ()


def validate_manifest(manifest: Manifest) -> None:
    """Check every entry (name, kind, channel, path inside the backup, no duplicates) before
    any path is read; the error names the entry."""
    seen: set[tuple[int, str]] = set()
    for i, entry in enumerate(manifest.files, 1):
        where = f"folder: {MANIFEST} file {i}"
        if not isinstance(entry.channel, int) or not 1 <= entry.channel <= 3:
            raise UsageError(f"{where}: channel must be 1-3, not {entry.channel!r}")
        if not isinstance(entry.name, str):
            raise UsageError(f"{where}: name must be text, not {entry.name!r}")
        name = FileName.parse(entry.name)
        if str(name) != entry.name or name.problem() is not None:
            raise UsageError(f"{where}: name {entry.name!r}: {NAME_RULE}")
        expected = relative_path(entry.channel, name)
        if entry.path != expected:
            raise UsageError(
                f"{where}: path {entry.path!r} must be {expected!r} (inside the backup folder)"
            )
        for number in ("job_number", "size_kb", "steps", "bytes"):
            value = getattr(entry, number)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise UsageError(f"{where}: {number} must be a whole number, not {value!r}")
        if not 0 <= entry.job_number <= 200:
            raise UsageError(f"{where}: job_number {entry.job_number} is out of range 0..200")
        if not isinstance(entry.sha256, str) or len(entry.sha256) != 64:
            raise UsageError(f"{where}: sha256 must be 64 hex digits")
        key = (entry.channel, name.key)
        if key in seen:
            raise UsageError(f"{where}: {expected} is listed twice")
        seen.add(key)
