"""The backup and the restore, as plans: what they ask of the line, and of the store.

A plan touches no file itself: every file operation is a store call it asks its client to
run (:func:`~robostar.client.plan.blocking`), in place for Client and in a worker thread for
AsyncClient, so that a slow disk never holds an event loop.

Neither direction loses data. A backup reads the controller's files into a temporary folder
that the store swaps into place only when complete (see :mod:`robostar.backup.store`). A
restore first validates the whole manifest (names, kinds, channels, paths inside the
backup), then reads every file, then reads the target (identity, file list, contents) and
writes nothing if any check fails; only then does it upload what is new or changed, reading
each upload back before the next. A restore that fails or is interrupted after that point
says so (RestoreIncompleteError, RestoreInterrupted): which files are written and verified,
which is in doubt, which were not touched.
"""

from __future__ import annotations

import fnmatch
import hashlib
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from dataclasses import replace as with_changes  # `replace` is backup_plan's option
from datetime import UTC, datetime
from functools import partial

from robostar.backup import store
from robostar.backup.errors import RestoreIncompleteError, RestoreInterrupted, RestoreState
from robostar.backup.manifest import (
    MANIFEST,
    BackupFile,
    Manifest,
    file_bytes,
    file_lines,
    relative_path,
    validate_manifest,
)
from robostar.client.driver import upload_matches
from robostar.client.exchange import Progress
from robostar.client.files import download_job, download_points, point_lines
from robostar.client.plan import Blocking, Plan, blocking, call
from robostar.commands.files import DeleteFile, DownloadFile, ListFiles, UploadFile
from robostar.commands.identity import is_simulator_identity
from robostar.commands.status import ReadInfo
from robostar.errors import FieldError, RobostarError, UploadIncompleteError, UsageError
from robostar.protocol.fields import FileName
from robostar.types import ControllerInfo, CoordSystem, FileRecord, JobFile, PointFile, RobotType

__all__ = ["RestoreDiff", "backup_plan", "restore_plan"]


def _report(progress: Progress | None, done: int, total: int) -> None:
    if progress is not None:
        progress(done, total)


# -- backup -----------------------------------------------------------------------------------


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
    cannot be written here raises :class:`~robostar.backup.BackupWriteError` (the previous
    backup is intact). The returned manifest's ``folder`` is where the new backup is.
    """
    root = store.folder_path(folder)
    previous = yield from blocking(store.previous_backup, root, keep)
    # Cancelled while the store makes the temporary folder, the plan never learns its name:
    # the client removes it (undo).
    pending: store.PendingBackup = yield Blocking(partial(store.start, root, keep), store.discard)
    try:
        manifest = yield from _download_all(pending, progress, target, previous, replace)
        yield from blocking(store.put_in_place, pending, previous)
    except GeneratorExit:
        # Closed by its driver, the plan can ask for nothing more: the one file operation
        # done in place, so that no half-written backup is left.
        store.discard(pending)
        raise
    except BaseException:
        yield from blocking(store.discard, pending)
        raise
    yield from blocking(store.tidy, pending)
    return with_changes(manifest, folder=str(pending.final))


def _download_all(
    pending: store.PendingBackup,
    progress: Progress | None,
    target: str | None,
    previous: Manifest | None,
    replace: bool,
) -> Plan[Manifest]:
    info = yield from call(ReadInfo())
    if previous is not None:
        # After AD (which says whether this is a simulator), before any file is read.
        _refuse_other_source(pending, previous, target, _is_simulator(target, info), replace)
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
        data = file_bytes(lines)
        relative = relative_path(channel_number, name)
        yield from blocking(store.write_file, pending, relative, data)
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
    yield from blocking(store.write_manifest, pending, manifest)
    return manifest


def _is_simulator(target: str | None, info: ControllerInfo) -> bool | None:
    """A simulator: a sim:// target, or a controller whose AD identity says so (a simulator's
    version always ends in -SIM); None when neither is known."""
    if target is not None and target.strip().lower().startswith("sim:"):
        return True
    if is_simulator_identity(info):
        return True
    return False if target is not None else None


def _same_target(before: str | None, now: str | None) -> bool:
    """Is ``now`` the target ``before`` was read from (True when either is not known)? Every
    ``sim://`` is the built-in simulator, started afresh each time, whatever its options."""
    if before is None or now is None:
        return True
    if before.strip().lower().startswith("sim:") and now.strip().lower().startswith("sim:"):
        return True
    return before == now


def _refuse_other_source(
    pending: store.PendingBackup,
    previous: Manifest,
    target: str | None,
    simulator: bool | None,
    replace: bool,
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
            f"folder: {str(pending.final)!r} holds a backup of "
            f"{what(previous.target, was_simulator)}, not of {what(target, simulator)}; give "
            "--replace (replace=True in Python) to replace it, or another folder (nothing was "
            "replaced; only the controller's identity, AD, was read)"
        )


# -- restore ----------------------------------------------------------------------------------


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

    Once writing has begun, a failure raises :class:`~robostar.backup.RestoreIncompleteError`
    and Ctrl-C :class:`~robostar.backup.RestoreInterrupted` (a KeyboardInterrupt), both with a
    :class:`~robostar.backup.RestoreState`: the controller is half-restored, and running the
    restore again finishes it.
    """
    root = store.folder_path(folder)
    manifest = yield from blocking(store.read_manifest, root)
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
    uploads = []
    for entry in entries:
        name = FileName.parse(entry.name)
        data = yield from blocking(store.read_file, root, relative_path(entry.channel, name))
        uploads.append(_upload_of(entry, name, data))

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
    chosen = set(diff.new + diff.changed)
    writes = [u for u in uploads if relative_path(u.channel, u.file) in chosen]
    yield from _write_phase(str(root), writes, diff.delete, progress)
    return with_changes(manifest, folder=str(root))


def _upload_of(entry: BackupFile, name: FileName, data: bytes) -> UploadFile:
    """A file of the backup as its upload, checked against the manifest, every line encoded
    before anything is sent."""
    relative = relative_path(entry.channel, name)
    if len(data) != entry.bytes or hashlib.sha256(data).hexdigest() != entry.sha256:
        raise UsageError(f"folder: {relative} does not match its size and sha256 in {MANIFEST}")
    try:
        upload = UploadFile(entry.channel, name, entry.job_number, file_lines(data))
        upload.encode()  # every line is checked before anything is sent
    except (UnicodeDecodeError, FieldError) as exc:
        raise UsageError(f"folder: {relative} cannot be uploaded: {exc}") from exc
    return upload


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
    folder: str, writes: Sequence[UploadFile], deletes: Sequence[str], progress: Progress | None
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
        pending = [relative_path(u.channel, u.file) for u in writes] + list(deletes)
        touched = {*verified, *deleted, doubt}  # doubt is "" between files
        return RestoreState(
            folder,
            tuple(verified),
            tuple(deleted),
            doubt,
            why,
            tuple(p for p in pending if p not in touched),
        )

    doubt, step, name = "", "", ""  # the file being worked on, its step (FB, FA, FE)
    try:
        for upload in writes:
            doubt, step, name = relative_path(upload.channel, upload.file), "FB", str(upload.file)
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
        relative = relative_path(upload.channel, upload.file)
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
