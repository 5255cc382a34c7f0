"""Backup and restore moved to :mod:`robostar.backup`; these names stay importable from here."""

from robostar.backup import (
    MANIFEST,
    STALE_AFTER,
    BackupFile,
    BackupWriteError,
    Manifest,
    RestoreDiff,
    RestoreIncompleteError,
    RestoreInterrupted,
    RestoreState,
    backup_plan,
    is_backup,
    restore_plan,
    validate_manifest,
)

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
