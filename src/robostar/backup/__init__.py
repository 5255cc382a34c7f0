"""Backup and restore of every JOB and PNT file of a controller, with a JSON manifest.

:mod:`~robostar.backup.manifest` is the format of ``manifest.json``;
:mod:`~robostar.backup.store` does every file work on this computer (temporary folders,
the swap into place, generations and pruning, reading a backup back);
:mod:`~robostar.backup.plans` holds the backup and the restore as plans that ask only for
line exchanges and store calls, which ``Client.backup`` / ``Client.restore`` (and their
asyncio twins) run; :mod:`~robostar.backup.errors` their errors.
"""

from robostar.backup.errors import (
    BackupWriteError,
    RestoreIncompleteError,
    RestoreInterrupted,
    RestoreState,
)
from robostar.backup.manifest import MANIFEST, BackupFile, Manifest, validate_manifest
from robostar.backup.plans import RestoreDiff, backup_plan, restore_plan
from robostar.backup.store import STALE_AFTER, is_backup

__all__ = [
    "MANIFEST",
    "STALE_AFTER",
    "BackupFile",
    "BackupWriteError",
    "Manifest",
    "RestoreDiff",
    "RestoreIncompleteError",
    "RestoreInterrupted",
    "RestoreState",
    "backup_plan",
    "is_backup",
    "restore_plan",
    "validate_manifest",
]
