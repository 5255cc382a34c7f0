"""The backups on this computer: every file a backup or a restore reads or writes.

A backup is written into a temporary folder beside its target and swapped into place only
when complete, so an interrupted backup leaves the previous one intact; a non-empty folder
that is not a robostar backup is refused, and so is one holding anything besides the
previous backup's own files (a backup replaces its folder whole). With ``keep``, a folder
holds timestamped generations ``backup-<UTC time>``, pruned by their manifests' ``created``
time.

Each function here blocks on the disk, and the plans never call one themselves: they ask
their client to (:func:`robostar.client.plan.blocking`), which runs it inline (Client) or in
a worker thread (AsyncClient), so that a slow disk never holds an event loop.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from robostar.backup.errors import BackupWriteError
from robostar.backup.manifest import MANIFEST, Manifest, created_time, is_manifest
from robostar.errors import UsageError

__all__ = [
    "STALE_AFTER",
    "PendingBackup",
    "discard",
    "folder_path",
    "is_backup",
    "previous_backup",
    "put_in_place",
    "read_file",
    "read_manifest",
    "start",
    "tidy",
    "write_file",
    "write_manifest",
]

STALE_AFTER = 3600.0
"""A temporary folder of this module untouched for this long (seconds) was left by a backup
that was killed; a later backup removes it."""

_GENERATION_WORK = re.compile(r"\.backup-\d{8}T\d{12}Z\.[a-z0-9_]{8}\.(?:part|old)")
"""The temporary folders this module makes in a --keep folder (mkdtemp's 8 random characters)."""


def folder_path(folder: object) -> Path:
    """``folder`` as a Path (UsageError if it is not a path); nothing is read."""
    if not isinstance(folder, str | os.PathLike):
        raise UsageError(f"folder: must be a path, not {folder!r}")
    return Path(folder)


def is_backup(folder: Path) -> bool:
    """Does ``folder`` hold a robostar backup (a manifest this module wrote)?"""
    try:
        text = (folder / MANIFEST).read_text(encoding="utf-8")
    except (OSError, ValueError):  # ValueError: not UTF-8
        return False
    return is_manifest(text)


# -- backing up -------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class PendingBackup:
    """A backup being written: ``work``, the temporary folder it is written into, becomes
    ``final`` when it is complete. ``kept`` says, for an error message, what a failure leaves
    intact; ``started`` (time.time()) tells a killed backup's leftovers from a running one's."""

    root: Path
    final: Path
    work: Path
    keep: int | None
    started: float
    kept: str


def previous_backup(root: Path, keep: int | None) -> Manifest | None:
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


def start(root: Path, keep: int | None) -> PendingBackup:
    """Make the temporary folder a new backup of ``root`` is written into (beside ``root``,
    or in it as a new generation with ``keep``)."""
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
    return PendingBackup(root, final, work, keep, started, kept)


def write_file(pending: PendingBackup, relative: str, data: bytes) -> None:
    """Write one file of the backup (``relative``: ``ch<N>/<NAME>``); BackupWriteError if it
    cannot be written."""
    path = pending.work / relative
    try:
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(data)
    except OSError as exc:
        raise _write_failed(pending, exc) from exc


def write_manifest(pending: PendingBackup, manifest: Manifest) -> None:
    """Write the manifest, which goes last: a folder without one is never taken for a
    complete backup."""
    try:
        (pending.work / MANIFEST).write_text(manifest.to_json(), encoding="utf-8")
    except OSError as exc:
        raise _write_failed(pending, exc) from exc


def put_in_place(pending: PendingBackup, previous: Manifest | None) -> None:
    """Swap the complete backup into place; a previous backup there is removed only after the
    new one is in place, and only if nobody put a file of theirs there meanwhile."""
    if previous is not None:
        # Checked again at the moment of truth: a file someone put there since is kept.
        _refuse_foreign(pending.final, previous)
    try:
        _swap_into_place(pending.work, pending.final)
    except OSError as exc:
        raise _write_failed(pending, exc) from exc


def tidy(pending: PendingBackup) -> None:
    """After a backup is in place: prune the generations beyond ``keep``, and remove what
    killed backups left."""
    if pending.keep is not None:
        _prune(pending.root, pending.final, pending.keep)
        _remove_stale_work(pending.root, _GENERATION_WORK, pending.started)
    else:
        folder = pending.final
        _remove_stale_work(folder.parent, _work_pattern(folder.name), pending.started)


def discard(pending: PendingBackup) -> None:
    """Remove a backup that was not finished (whatever of it was written)."""
    shutil.rmtree(pending.work, ignore_errors=True)


def _stamp() -> str:
    return datetime.now(UTC).strftime("backup-%Y%m%dT%H%M%S%fZ")


def _write_failed(pending: PendingBackup, exc: OSError) -> BackupWriteError:
    where = f" ({exc.filename})" if exc.filename else ""
    target = pending.final
    return BackupWriteError(
        f"cannot write the backup at {str(target)!r}: {exc.strerror or exc}{where}; {pending.kept}",
        str(target),
    )


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
        created = created_time((path / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):  # ValueError: not UTF-8
        created = None
    return (mtime if created is None else created), mtime, path.name


def _prune(root: Path, new: Path, keep: int) -> None:
    """Keep ``new`` (the backup just written) and the newest ``keep - 1`` other generations,
    newest by their manifests' ``created`` time (whatever their folder names say)."""
    others = [p for p in root.iterdir() if _is_generation(p) and p.name != new.name]
    others.sort(key=_created, reverse=True)
    for old in others[keep - 1 :]:
        shutil.rmtree(old, ignore_errors=True)


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


# -- restoring --------------------------------------------------------------------------------


def read_manifest(root: Path) -> Manifest:
    """The manifest of the backup in ``root`` (UsageError if it cannot be read or is not one)."""
    try:
        text = (root / MANIFEST).read_text(encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"folder: cannot read {MANIFEST}: {exc}") from exc
    return Manifest.from_json(text)


def read_file(root: Path, relative: str) -> bytes:
    """The bytes of one file of the backup in ``root``; UsageError if ``relative`` leads
    outside it or cannot be read."""
    path = (root / relative).resolve()
    if root.resolve() not in path.parents:
        raise UsageError(f"folder: {relative} leads outside the backup folder")
    try:
        return path.read_bytes()
    except OSError as exc:
        raise UsageError(f"folder: cannot read {relative}: {exc}") from exc
