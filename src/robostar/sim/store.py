"""The simulator's state directory: one JSON snapshot, replaced atomically on every save.

A save writes a temporary file in the same directory, flushes and fsyncs it, renames it over
``state.json`` with :func:`os.replace` and fsyncs the directory, so that the rename itself is on
disk. A crash at any point leaves either the old snapshot or the new one, never a mix or nothing.
One simulator per directory: two writers would overwrite each other's snapshots.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from pathlib import Path
from typing import Any

from robostar.errors import UsageError

__all__ = ["STATE_FILE", "StateFileError", "StateStore"]

STATE_FILE = "state.json"
_TEMP_PREFIX = ".state-"
_TEMP_SUFFIX = ".tmp"


class StateFileError(UsageError):
    """A state file the simulator cannot start from; the message names the file."""

    hint = "Fix the file, or remove it to start afresh. The simulator did not start."
    """What to do about it (the console shows it in place of a usage hint)."""


class _NotANumber:
    """NaN, Infinity or -Infinity read from a state file (JSON has none): kept in place while
    parsing, so that the error can name the key that holds it."""

    def __init__(self, name: str) -> None:
        self.name = name


def _first_not_a_number(value: Any, path: str) -> tuple[str, str] | None:
    """The key path and name of the first NaN or Infinity in ``value``, or None."""
    if isinstance(value, _NotANumber):
        return path, value.name
    if isinstance(value, dict):
        items = ((f"{path}.{key}" if path else str(key), item) for key, item in value.items())
    elif isinstance(value, list):
        items = ((f"{path}[{i}]", item) for i, item in enumerate(value))
    else:
        return None
    for where, item in items:
        found = _first_not_a_number(item, where)
        if found is not None:
            return found
    return None


class StateStore:
    """Loads and saves the controller's snapshot (a JSON object) in ``directory``."""

    def __init__(self, directory: str | os.PathLike[str]) -> None:
        path = Path(directory)
        if path.exists() and not path.is_dir():
            raise UsageError(f"state directory: {str(path)!r} exists and is not a directory")
        self.directory = path
        self.path = path / STATE_FILE

    def load(self) -> dict[str, Any] | None:
        """The last saved snapshot, or None when nothing was saved yet."""
        self._remove_stale_temps()
        try:
            text = self.path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return None
        except UnicodeDecodeError as exc:
            raise StateFileError(
                f"state directory: {str(self.path)!r} is not UTF-8 text (byte {exc.start}); "
                "fix it or remove it to start afresh"
            ) from None
        try:
            snapshot = json.loads(text, parse_constant=_NotANumber)
        except json.JSONDecodeError as exc:
            raise StateFileError(
                f"state directory: {str(self.path)!r} is not valid JSON ({exc}); "
                "fix it or remove it to start afresh"
            ) from None
        if not isinstance(snapshot, dict):
            raise StateFileError(f"state directory: {str(self.path)!r} does not hold a JSON object")
        found = _first_not_a_number(snapshot, "")
        if found is not None:
            where, name = found
            raise StateFileError(f"{self.path}: {where}: {name} is not a number")
        return snapshot

    def save(self, snapshot: dict[str, Any]) -> None:
        """Replace the saved snapshot; on any failure the previous one stays as it was."""
        if not isinstance(snapshot, dict):
            raise UsageError(f"snapshot: {type(snapshot).__name__} is not a dict")
        # Serialise first: a value JSON cannot hold fails here, before any file is touched.
        text = json.dumps(snapshot, indent=1, sort_keys=True, allow_nan=False)
        self.directory.mkdir(parents=True, exist_ok=True)
        fd, temp = tempfile.mkstemp(prefix=_TEMP_PREFIX, suffix=_TEMP_SUFFIX, dir=self.directory)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as handle:
                handle.write(text)
                handle.write("\n")
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(temp, self.path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(temp)
            raise
        self._sync_directory()

    def _sync_directory(self) -> None:
        # The rename is only durable once the directory entry is on disk too. Some platforms
        # (Windows) cannot open a directory; there the rename is as durable as it gets.
        try:
            fd = os.open(self.directory, os.O_RDONLY)
        except OSError:
            return
        try:
            os.fsync(fd)
        finally:
            os.close(fd)

    def _remove_stale_temps(self) -> None:
        # A process killed between mkstemp and os.replace leaves its temporary file behind.
        if not self.directory.is_dir():
            return
        for stale in self.directory.glob(f"{_TEMP_PREFIX}*{_TEMP_SUFFIX}"):
            with contextlib.suppress(OSError):
                stale.unlink()
