"""Backup and restore of every JOB and PNT file of a controller, with a JSON manifest.

A backup folder holds ``ch<N>/<NAME>.JOB`` and ``ch<N>/<NAME>.PNT`` (one step or point line per
text line, PNT points in angle coordinates in FA's point-line format) and ``manifest.json``:
the controller's AD info, and per file its channel, name, JOB number, size, steps, byte count
and sha256.

Neither direction loses data. A backup is written into a temporary folder beside the target
and swapped into place only when complete, so an interrupted backup leaves the previous one
intact; a non-empty folder that is not a robostar backup is refused. A restore first validates
the whole manifest (names, kinds, channels, paths inside the backup), then reads every file,
then reads the target (identity, file list, contents) and writes nothing if any check fails;
only then does it upload what is new or changed, reading each upload back before the next. A
restore that fails or is interrupted after that point says so (RestoreIncompleteError,
RestoreInterrupted): which files are written and verified, which is in doubt, which were not
touched.
"""

from __future__ import annotations

import fnmatch
import hashlib
import json
import os
import re
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from dataclasses import replace as with_changes  # `replace` is backup_plan's option
from datetime import UTC, datetime
from pathlib import Path

from robostar.client.driver import upload_matches
from robostar.client.exchange import Progress
from robostar.client.files import NAME_RULE, download_job, download_points, point_lines
from robostar.client.plan import Plan, call
from robostar.commands.files import DeleteFile, DownloadFile, ListFiles, UploadFile
from robostar.commands.identity import is_simulator_identity
from robostar.commands.status import ReadInfo
from robostar.errors import FieldError, RobostarError, UploadIncompleteError, UsageError
from robostar.protocol.fields import FileName
from robostar.types import (
    ChannelInfo,
    ControllerInfo,
    CoordSystem,
    FileRecord,
    JobFile,
    PointFile,
    RobotType,
)

__all__ = [
    "MANIFEST",
    "BackupFile",
    "BackupWriteError",
    "Manifest",
    "RestoreDiff",
    "RestoreIncompleteError",
    "RestoreInterrupted",
    "RestoreState",
    "backup_plan",
    "restore_plan",
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


def _folder(folder: object) -> Path:
    if not isinstance(folder, str | os.PathLike):
        raise UsageError(f"folder: must be a path, not {folder!r}")
    return Path(folder)


def _relative(channel: int, name: FileName) -> str:
    return f"ch{channel}/{name}"


def _text(lines: tuple[str, ...]) -> bytes:
    # Job lines outside ASCII are refused by download_job; points are formatted as ASCII.
    return "".join(line + "\n" for line in lines).encode("ascii")


def _lines(data: bytes) -> tuple[str, ...]:
    text = data.decode("ascii")
    return tuple(text.split("\n")[:-1]) if text else ()


def _report(progress: Progress | None, done: int, total: int) -> None:
    if progress is not None:
        progress(done, total)


class BackupWriteError(RobostarError, OSError):
    """The backup could not be written on this computer (disk full, no permission): the
    previous backup is intact; ``path`` is where it was being written."""

    def __init__(self, message: str, path: str) -> None:
        self.path = path
        super().__init__(message)


def _write_failed(target: Path, exc: OSError, kept: str) -> BackupWriteError:
    where = f" ({exc.filename})" if exc.filename else ""
    return BackupWriteError(
        f"cannot write the backup at {str(target)!r}: {exc.strerror or exc}{where}; {kept}",
        str(target),
    )


def is_backup(folder: Path) -> bool:
    """Does ``folder`` hold a robostar backup (a manifest this module wrote)?"""
    try:
        data = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and data.get("format") == FORMAT


_GENERATION_WORK = re.compile(r"\.backup-\d{8}T\d{12}Z\.[a-z0-9_]{8}\.(?:part|old)")
"""The temporary folders this module makes in a --keep folder (mkdtemp's 8 random characters)."""

STALE_AFTER = 3600.0
"""A temporary folder of this module untouched for this long (seconds) was left by a backup
that was killed; a later backup removes it."""


def _work_pattern(target_name: str) -> re.Pattern[str]:
    """The temporary folders this module makes beside a backup named ``target_name``."""
    return re.compile(rf"\.{re.escape(target_name)}\.[a-z0-9_]{{8}}\.(?:part|old)")


def _foreign(root: Path, manifest: Manifest) -> list[str]:
    """What ``root`` holds besides the backup ``manifest`` describes (its manifest, its files
    and their ``ch<N>`` folders), as paths relative to ``root``: a backup replaces its folder
    whole, so anything else would be deleted with the previous backup."""
    own = {MANIFEST, *(f.path for f in manifest.files)}
    folders = {str(Path(path).parent) for path in own} - {"."}
    found = []
    try:
        for item in sorted(root.rglob("*")):
            relative = item.relative_to(root).as_posix()
            if item.is_symlink() or relative not in (folders if item.is_dir() else own):
                found.append(relative)
    except OSError as exc:
        raise UsageError(f"folder: cannot read {str(root)!r}: {exc}") from exc
    return found


def _previous(root: Path, keep: int | None) -> Manifest | None:
    """Refuse, before anything is sent, a target that a backup must not replace; the manifest
    of the previous backup that it will replace, if there is one."""
    if root.exists() and not root.is_dir():
        raise UsageError(f"folder: {str(root)!r} exists and is not a folder")
    if keep is None:
        if not root.is_dir() or not any(root.iterdir()):
            return None
        if not is_backup(root):
            raise UsageError(
                f"folder: {str(root)!r} is not empty and is not a robostar backup; "
                "give an empty or new folder (nothing was replaced)"
            )
        previous = Manifest.from_json((root / MANIFEST).read_text(encoding="utf-8"))
        _refuse_foreign(root, previous)
        return previous
    if isinstance(keep, bool) or not isinstance(keep, int) or keep < 1:
        raise UsageError(f"keep: must be a whole number 1 or more, not {keep!r}")
    if root.is_dir():
        strays = [
            p.name
            for p in root.iterdir()
            if not _is_generation(p) and not _GENERATION_WORK.fullmatch(p.name)
        ]
        if strays:
            raise UsageError(
                f"folder: {str(root)!r} holds {strays[0]!r}, which is not a backup generation; "
                "--keep needs a folder of its own"
            )
    return None


def _refuse_foreign(root: Path, previous: Manifest) -> None:
    """Refuse to replace a backup folder that holds files of someone else's (notes, photos):
    they would go with the previous backup, and no option deletes them."""
    foreign = _foreign(root, previous)
    if foreign:
        more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
        raise UsageError(
            f"folder: {str(root)!r} holds {foreign[0]!r}{more}, which is not part of the backup "
            "there; a backup replaces its folder whole, so move it out first or give another "
            "folder (nothing was replaced)"
        )


def _same_target(before: str | None, now: str | None) -> bool:
    """Is ``now`` the target ``before`` was read from (True when either is not known)? Every
    ``sim://`` is the built-in simulator, started afresh each time, whatever its options."""
    if before is None or now is None:
        return True
    if before.strip().lower().startswith("sim:") and now.strip().lower().startswith("sim:"):
        return True
    return before == now


def _refuse_other_source(
    root: Path, previous: Manifest, target: str | None, simulator: bool | None, replace: bool
) -> None:
    """Refuse, unless ``replace``, to replace a backup read from another target, or from a
    simulator by a real controller's (or the other way round): one folder is one robot's."""
    if replace:
        return
    # A manifest written before "simulator" was recorded: its AD identity still says.
    was_simulator = (
        previous.simulator
        if previous.simulator is not None
        else is_simulator_identity(previous.controller)
    )

    def what(url: str | None, sim: bool | None) -> str:
        kind = {True: "a simulator", False: "a controller", None: "unknown"}[sim]
        return f"{url} ({kind})" if url else kind

    differs = simulator is not None and was_simulator is not simulator
    differs |= not _same_target(previous.target, target)
    if differs:
        raise UsageError(
            f"folder: {str(root)!r} holds a backup of {what(previous.target, was_simulator)}, "
            f"not of {what(target, simulator)}; give --replace (replace=True in Python) to "
            "replace it, or another folder (nothing was replaced; only the controller's "
            "identity, AD, was read)"
        )


def _is_generation(path: Path) -> bool:
    return path.is_dir() and path.name.startswith("backup-") and is_backup(path)


def _newest_change(path: Path) -> float:
    """The latest modification time of ``path`` or anything in it (0 if it cannot be read)."""
    try:
        newest = path.lstat().st_mtime
        for item in path.rglob("*"):
            newest = max(newest, item.lstat().st_mtime)
    except OSError:
        return 0.0
    return newest


def _remove_stale_work(folder: Path, pattern: re.Pattern[str], started: float) -> None:
    """Remove temporary folders of this module that a killed backup left in ``folder``: only
    folders named as this module names them, and only those nothing touched for STALE_AFTER
    seconds before this run started (a backup still running elsewhere keeps its own)."""
    try:
        entries = list(folder.iterdir())
    except OSError:
        return
    for entry in entries:
        if not pattern.fullmatch(entry.name) or entry.is_symlink() or not entry.is_dir():
            continue
        if _newest_change(entry) < started - STALE_AFTER:
            shutil.rmtree(entry, ignore_errors=True)


def _created(path: Path) -> tuple[float, float, str]:
    """How new a generation is: its manifest's ``created`` time, then the folder's mtime."""
    try:
        mtime = path.stat().st_mtime
    except OSError:
        mtime = 0.0
    try:
        data = json.loads((path / MANIFEST).read_text(encoding="utf-8"))
        created = datetime.fromisoformat(str(data["created"])).timestamp()
    except (OSError, ValueError, KeyError, TypeError):
        created = mtime
    return created, mtime, path.name


def _prune(root: Path, new: Path, keep: int) -> None:
    """Keep ``new`` (the backup just written) and the newest ``keep - 1`` other generations,
    newest by their manifests' ``created`` time (whatever their folder names say)."""
    others = [p for p in root.iterdir() if _is_generation(p) and p.name != new.name]
    others.sort(key=_created, reverse=True)
    for old in others[keep - 1 :]:
        shutil.rmtree(old, ignore_errors=True)


def _stamp() -> str:
    return datetime.now(UTC).strftime("backup-%Y%m%dT%H%M%S%fZ")


def _is_simulator(target: str | None, info: ControllerInfo) -> bool | None:
    """A simulator: a sim:// target, or a controller whose AD identity says so (a simulator's
    version always ends in -SIM); None when neither is known."""
    if target is not None and target.strip().lower().startswith("sim:"):
        return True
    if is_simulator_identity(info):
        return True
    return False if target is not None else None


def backup_plan(
    folder: str | os.PathLike[str],
    progress: Progress | None,
    keep: int | None = None,
    *,
    target: str | None = None,
    replace: bool = False,
) -> Plan[Manifest]:
    """Download every file of every defined channel into ``folder``; ``progress`` per file.

    Without ``keep`` the backup is ``folder`` itself (a previous backup there is replaced only
    once the new one is complete). A folder holding anything besides a previous backup's own
    files is refused (nothing of anyone else's is ever deleted), and so is a previous backup
    of another ``target``, or of a simulator when this is a controller (or the other way
    round), unless ``replace``. With ``keep=N``, ``folder`` holds timestamped generations
    ``backup-<UTC time>``: the new one is always kept, with the N-1 newest others (by the time
    in their manifests). ``target`` (the client's URL) is recorded in the manifest. A file that
    cannot be written here raises :class:`BackupWriteError` (the previous backup is intact).
    The returned manifest's ``folder`` is where the new backup is.
    """
    root = _folder(folder)
    previous = _previous(root, keep)
    started = time.time()
    final = root / _stamp() if keep is not None else root
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".part", dir=final.parent))
        work.chmod(0o755)  # mkdtemp makes it private; a backup folder is an ordinary folder
    except OSError as exc:
        raise UsageError(f"folder: cannot create {str(root)!r}: {exc}") from exc
    if keep is not None:
        kept = "the previous backups in the folder are intact"
    elif final.exists():
        kept = "the previous backup is intact"
    else:
        kept = "there was no backup there to replace, and nothing half-written is left"
    try:
        manifest = yield from _download_all(
            work, progress, target, final, kept, previous=previous, replace=replace
        )
        if previous is not None:
            # Checked again at the moment of truth: a file someone put there since is kept.
            _refuse_foreign(final, previous)
        try:
            _swap_into_place(work, final)
        except OSError as exc:
            raise _write_failed(final, exc, kept) from exc
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    if keep is not None:
        _prune(root, final, keep)
        _remove_stale_work(root, _GENERATION_WORK, started)
    else:
        _remove_stale_work(final.parent, _work_pattern(final.name), started)
    return with_changes(manifest, folder=str(final))


def _download_all(
    work: Path,
    progress: Progress | None,
    target: str | None,
    final: Path,
    kept: str,
    *,
    previous: Manifest | None = None,
    replace: bool = False,
) -> Plan[Manifest]:
    info = yield from call(ReadInfo())
    if previous is not None:
        # After AD (which says whether this is a simulator), before any file is read.
        _refuse_other_source(final, previous, target, _is_simulator(target, info), replace)
    listing = []
    for channel in info.channels[: info.max_channels]:
        if channel.robot_type is RobotType.NOT_DEFINED:
            continue
        records = yield from call(ListFiles(channel.channel, "*"))
        listing += [(channel.channel, record) for record in records]
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
        path = work / relative
        try:
            path.parent.mkdir(exist_ok=True)
            path.write_bytes(data)
        except OSError as exc:
            raise _write_failed(final, exc, kept) from exc
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
    manifest = Manifest(created, info, tuple(files), target, _is_simulator(target, info))
    # The manifest goes last: a folder without one is never taken for a complete backup.
    try:
        (work / MANIFEST).write_text(manifest.to_json(), encoding="utf-8")
    except OSError as exc:
        raise _write_failed(final, exc, kept) from exc
    return manifest


def _swap_into_place(work: Path, target: Path) -> None:
    """Rename the finished backup to ``target``; a previous backup there is removed only after
    the new one is in place."""
    if not target.exists():
        os.replace(work, target)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".old", dir=target.parent))
    old.rmdir()
    os.replace(target, old)
    try:
        os.replace(work, target)
    except BaseException:
        os.replace(old, target)
        raise
    shutil.rmtree(old, ignore_errors=True)


# -- restore ----------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class RestoreState:
    """Where a restore that stopped part-way left the controller (files as ``ch<N>/<NAME>``).

    ``verified``: written and read back the same; ``deleted``: deleted as asked; ``in_doubt``:
    the file being written, read back or deleted when it stopped, and ``why`` ("" for both when
    it stopped between two files); ``untouched``:
    the writes and deletions it did not reach. Running the restore again finishes it: its
    preflight writes only what still differs.
    """

    folder: str
    verified: tuple[str, ...]
    deleted: tuple[str, ...]
    in_doubt: str
    why: str
    untouched: tuple[str, ...]

    def describe(self) -> str:
        """The state in words, for a person."""

        def names(items: tuple[str, ...]) -> str:
            return ", ".join(items) if items else "none"

        text = (
            f"the restore of {self.folder!r} stopped part-way and the controller is "
            f"half-restored: written and verified: {names(self.verified)}; "
        )
        if self.deleted:
            text += f"deleted: {names(self.deleted)}; "
        doubt = f"{self.in_doubt} ({self.why})" if self.in_doubt else "none"
        return text + f"in doubt: {doubt}; not touched: {names(self.untouched)}"

    hint = (
        "Run the same restore again: its preflight compares every file and writes only what "
        "still differs."
    )

    def as_json(self) -> dict[str, object]:
        return {
            "folder": self.folder,
            "half_restored": True,
            "verified": list(self.verified),
            "deleted": list(self.deleted),
            "in_doubt": self.in_doubt or None,
            "why": self.why or None,
            "not_touched": list(self.untouched),
            "hint": self.hint,
        }


class RestoreIncompleteError(RobostarError):
    """A restore failed part-way through its writes: the controller is half-restored.
    ``state`` says what was written and verified, what is in doubt and what was not touched;
    ``__cause__`` is the error that stopped it."""

    def __init__(self, state: RestoreState) -> None:
        self.state = state
        super().__init__(f"{state.describe()}. {state.hint}")


class RestoreInterrupted(KeyboardInterrupt):
    """Ctrl-C (KeyboardInterrupt) during a restore's writes, with the same ``state`` as
    :class:`RestoreIncompleteError`: still a KeyboardInterrupt for whoever catches one."""

    def __init__(self, state: RestoreState) -> None:
        self.state = state
        super().__init__(f"{state.describe()}. {state.hint}")


@dataclass(frozen=True, slots=True)
class RestoreDiff:
    """What a restore would do, per file (``ch<N>/<NAME>``), found by the preflight.

    ``extra`` are files on the controller that the backup does not hold: kept, unless the
    restore was asked to delete them (``delete`` then lists the JOB files it would delete;
    PNT files cannot be deleted).
    """

    new: tuple[str, ...] = ()
    changed: tuple[str, ...] = ()
    unchanged: tuple[str, ...] = ()
    extra: tuple[str, ...] = ()
    delete: tuple[str, ...] = ()
    identity: tuple[str, ...] = field(default=())

    @property
    def writes(self) -> int:
        return len(self.new) + len(self.changed) + len(self.delete)


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
        expected = _relative(entry.channel, name)
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


def _read_backup(root: Path, entries: Sequence[BackupFile]) -> list[UploadFile]:
    """Every chosen file of the backup as its upload, each checked against the manifest."""
    uploads = []
    resolved_root = root.resolve()
    for entry in entries:
        name = FileName.parse(entry.name)
        relative = _relative(entry.channel, name)
        path = (root / relative).resolve()
        if resolved_root not in path.parents:
            raise UsageError(f"folder: {relative} leads outside the backup folder")
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise UsageError(f"folder: cannot read {relative}: {exc}") from exc
        if len(data) != entry.bytes or hashlib.sha256(data).hexdigest() != entry.sha256:
            raise UsageError(f"folder: {relative} does not match its size and sha256 in {MANIFEST}")
        try:
            upload = UploadFile(entry.channel, name, entry.job_number, _lines(data))
            upload.encode()  # every line is checked before anything is sent
        except (UnicodeDecodeError, FieldError) as exc:
            raise UsageError(f"folder: {relative} cannot be uploaded: {exc}") from exc
        uploads.append(upload)
    return uploads


def _identity(saved: ControllerInfo, target: ControllerInfo, channels: set[int]) -> list[str]:
    """How the target differs from the controller the backup came from, per restored channel."""
    problems = []
    if saved.version != target.version:
        problems.append(f"version: backup {saved.version!r}, controller {target.version!r}")
    theirs = {ch.channel: ch for ch in target.channels[: target.max_channels]}
    for ch in saved.channels:
        if ch.channel not in channels:
            continue
        other = theirs.get(ch.channel)
        if other is None:
            problems.append(f"channel {ch.channel}: the controller does not have it")
            continue
        if ch.robot_type is not other.robot_type:
            problems.append(
                f"channel {ch.channel} robot type: backup {ch.robot_type.name}, "
                f"controller {other.robot_type.name}"
            )
        if tuple(ch.axes_in_use) != tuple(other.axes_in_use):
            problems.append(
                f"channel {ch.channel} axes: backup {list(ch.axes_in_use)}, "
                f"controller {list(other.axes_in_use)}"
            )
    return problems


def _same(upload: UploadFile, content: JobFile | PointFile) -> bool:
    return upload_matches(upload, content)


def restore_plan(
    folder: str | os.PathLike[str],
    progress: Progress | None,
    *,
    channels: Sequence[int] | None = None,
    only: str | None = None,
    dry_run: bool = False,
    confirm: Callable[[RestoreDiff], bool] | None = None,
    delete_extra: bool = False,
    ignore_identity: bool = False,
) -> Plan[Manifest]:
    """Preflight, then upload what is new or changed and read each upload back.

    The preflight validates the manifest, reads every chosen file of the backup, and reads
    the target (AD identity, FD lists, FA of each file present on both sides); if anything
    fails, or ``confirm(diff)`` says no, or ``dry_run``, nothing is written (``confirm`` sees
    the diff in a dry run as well, and its answer is then ignored). ``channels`` and
    ``only`` (a name pattern such as ``"*.PNT"``) choose files; ``progress(done, total)``
    counts the writes and the read-backs (each file is read back before the next is written),
    then the deletions.

    Once writing has begun, a failure raises :class:`RestoreIncompleteError` and Ctrl-C
    :class:`RestoreInterrupted` (a KeyboardInterrupt), both with a :class:`RestoreState`:
    the controller is half-restored, and running the restore again finishes it.
    """
    root = _folder(folder)
    try:
        text = (root / MANIFEST).read_text(encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"folder: cannot read {MANIFEST}: {exc}") from exc
    manifest = Manifest.from_json(text)
    validate_manifest(manifest)
    wanted = set(channels) if channels is not None else {1, 2, 3}
    if not wanted <= {1, 2, 3}:
        raise UsageError(f"channels: channels are 1-3, not {sorted(wanted)}")
    entries = [
        e
        for e in manifest.files
        if e.channel in wanted and (only is None or fnmatch.fnmatch(e.name.upper(), only.upper()))
    ]
    if only is not None and not entries and not delete_extra:
        # A typo in the pattern would otherwise restore nothing and report success.
        _refuse_unmatched(only, manifest, wanted)
    uploads = _read_backup(root, entries)

    target_info = yield from call(ReadInfo())
    defined = {
        ch.channel
        for ch in manifest.controller.channels[: manifest.controller.max_channels]
        if ch.robot_type is not RobotType.NOT_DEFINED
    }
    restored = {u.channel for u in uploads} | (wanted & defined if delete_extra else set())
    identity = _identity(manifest.controller, target_info, restored)
    if identity and not ignore_identity:
        raise UsageError(
            "folder: the controller is not the one the backup came from ("
            + "; ".join(identity)
            + "); nothing was written"
        )
    diff = yield from _preflight(uploads, restored, only, delete_extra, identity)
    if only is not None and not (entries or diff.extra):
        # With delete_extra the pattern may choose files of the controller only; not even one.
        _refuse_unmatched(only, manifest, wanted)
    agreed = confirm(diff) if confirm is not None else True
    if dry_run or not agreed:
        return manifest
    writes = [u for u in uploads if _relative(u.channel, u.file) in set(diff.new + diff.changed)]
    yield from _write_phase(root, writes, diff.delete, progress)
    return with_changes(manifest, folder=str(root))


def _refuse_unmatched(only: str, manifest: Manifest, wanted: set[int]) -> None:
    """Refuse an ``only`` pattern that matches no file of the backup's chosen channels."""
    held = [e.path for e in manifest.files if e.channel in wanted]
    shown = ", ".join(held[:6]) + (f" and {len(held) - 6} more" if len(held) > 6 else "")
    where = "" if wanted == {1, 2, 3} else f" on channel {', '.join(map(str, sorted(wanted)))}"
    raise UsageError(
        f"only: {only!r} matches no file of the backup{where} (it holds {shown or 'none'}); "
        "nothing was written"
    )


def _write_phase(
    root: Path, writes: Sequence[UploadFile], deletes: Sequence[str], progress: Progress | None
) -> Plan[None]:
    """Upload each file and read it back before the next one, then delete: a failure or an
    interrupt part-way raises RestoreIncompleteError or RestoreInterrupted saying which files
    are written and verified, which one is in doubt and which were not touched."""
    total = len(writes) * 2 + len(deletes)
    done = 0
    verified: list[str] = []
    deleted: list[str] = []
    lines = [0, 0]  # FB lines the controller accepted, of how many

    def fed(count: int, of: int | None) -> None:
        lines[0], lines[1] = count, of or 0

    def state(doubt: str, why: str) -> RestoreState:
        pending = [_relative(u.channel, u.file) for u in writes] + list(deletes)
        touched = {*verified, *deleted, doubt}  # doubt is "" between files
        return RestoreState(
            str(root),
            tuple(verified),
            tuple(deleted),
            doubt,
            why,
            tuple(p for p in pending if p not in touched),
        )

    doubt, step, name = "", "", ""  # the file being worked on, its step (FB, FA, FE)
    try:
        for upload in writes:
            doubt, step, name = _relative(upload.channel, upload.file), "FB", str(upload.file)
            lines[0], lines[1] = 0, len(upload.lines)
            yield from call(upload, fed)
            step = "FA"
            done += 1
            _report(progress, done, total)
            content = yield from call(DownloadFile(upload.channel, upload.file, CoordSystem.ANGLE))
            if not _same(upload, content):
                raise UploadIncompleteError(
                    f"restore: {doubt} read back from the controller differs from the backup"
                )
            verified.append(doubt)
            doubt = step = ""
            done += 1
            _report(progress, done, total)
        for relative in deletes:
            doubt, step = relative, "FE"
            channel, file = relative.split("/", 1)
            yield from call(DeleteFile(int(channel[2:]), FileName.parse(file)))
            deleted.append(relative)
            doubt = step = ""
            done += 1
            _report(progress, done, total)
    except KeyboardInterrupt as exc:
        why = {
            "FB": f"FB {name} aborted after {lines[0]}/{lines[1]} lines; "
            "the file on the controller may be missing or old",
            "FA": "written, but interrupted while it was read back (FA); not verified",
            "FE": "interrupted while it was deleted (FE); it may or may not be deleted",
        }.get(step, "")
        raise RestoreInterrupted(state(doubt, why)) from exc
    except RobostarError as exc:
        why = {
            "FB": f"its upload (FB) failed: {exc}; the file on the controller may be missing "
            "or old",
            "FA": f"written, but not verified: {exc}",
            "FE": f"its deletion (FE) failed: {exc}",
        }.get(step, str(exc))
        raise RestoreIncompleteError(state(doubt, why)) from exc


def _preflight(
    uploads: Sequence[UploadFile],
    wanted: set[int],
    only: str | None,
    delete_extra: bool,
    identity: Sequence[str],
) -> Plan[RestoreDiff]:
    new: list[str] = []
    changed: list[str] = []
    unchanged: list[str] = []
    extra: list[str] = []
    channels = sorted({u.channel for u in uploads} | (wanted if delete_extra else set()))
    channels = [c for c in channels if c in wanted]
    present: dict[int, dict[str, FileRecord]] = {}
    for channel in channels:
        records = yield from call(ListFiles(channel, "*"))
        present[channel] = {FileName.parse(r.name).key: r for r in records}
    ours = {(u.channel, u.file.key) for u in uploads}
    renumbered: list[str] = []
    for upload in uploads:
        relative = _relative(upload.channel, upload.file)
        record = present[upload.channel].get(upload.file.key)
        if record is None:
            new.append(relative)
            continue
        content = yield from call(DownloadFile(upload.channel, upload.file, CoordSystem.ANGLE))
        if _same(upload, content):
            unchanged.append(relative)
            continue
        changed.append(relative)
        if upload.file.is_job and record.job_number != upload.job_number:
            # The controller refuses FB of a JOB file it holds under another number (with an
            # alarm): found here, nothing is written, rather than half-way through the writes.
            renumbered.append(
                f"{relative} is job number {record.job_number} on the controller, "
                f"{upload.job_number} in the backup"
            )
    if renumbered:
        raise UsageError(
            "folder: the controller refuses to overwrite a JOB file under another job number: "
            + "; ".join(renumbered)
            + ". Delete it on the controller first (`robostar files rm NAME`, -c N for channel "
            "N) so that the restore writes it anew, or leave it out with --only; nothing was "
            "written"
        )
    for channel in channels:
        for key, record in present[channel].items():
            name = record.name
            if (channel, key) in ours:
                continue
            if only is not None and not fnmatch.fnmatch(key, only.upper()):
                continue
            extra.append(f"ch{channel}/{name}")
    delete = tuple(e for e in extra if delete_extra and e.upper().endswith(".JOB"))
    return RestoreDiff(
        tuple(new), tuple(changed), tuple(unchanged), tuple(extra), delete, tuple(identity)
    )
