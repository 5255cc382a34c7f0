"""The errors of backups and restores, and the state a restore that stopped part-way left.

Each is a :class:`~robostar.errors.RobostarError` (RestoreInterrupted is a KeyboardInterrupt,
as Ctrl-C must stay one); errors.py's drawing lists them under the tree they join.
"""

from __future__ import annotations

from dataclasses import dataclass

from robostar.errors import RobostarError

__all__ = ["BackupWriteError", "RestoreIncompleteError", "RestoreInterrupted", "RestoreState"]


class BackupWriteError(RobostarError, OSError):
    """The backup could not be written on this computer (disk full, no permission): the
    previous backup is intact; ``path`` is where it was being written."""

    def __init__(self, message: str, path: str) -> None:
        self.path = path
        super().__init__(message)


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
