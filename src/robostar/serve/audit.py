"""The audit log: one JSON line per state-changing request (who, face, what, when, outcome).

The file is opened when the server starts, so a path that cannot be written stops the start
with a clear error. Should a write fail later (a full disk), the entry goes to the process log
instead, the request that was carried out is still answered as carried out (an answer lost
to the audit would invite a second copy of a motion), and the log is marked failed: every
further state change is refused (:class:`AuditError`, before anything reaches the wire) until
the file can be written again: proved by writing an entry ("audit log resumed after: ...")
before the next state change, since a full disk lets the file open and fails only the writes.
Stops are never refused for it.
"""

from __future__ import annotations

import contextlib
import json
import logging
import time
from pathlib import Path
from typing import IO

from robostar.errors import RobostarError
from robostar.serve.audit_words import is_routine

__all__ = ["AuditError", "AuditLog"]

log = logging.getLogger(__name__)


class AuditError(RobostarError):
    """The audit log cannot be written, so state changes are refused until it can."""


class AuditLog:
    """Appends to a JSONL file (or nowhere when ``path`` is None); flushed per record."""

    def __init__(self, path: str | Path | None) -> None:
        self.path = Path(path) if path is not None else None
        self._file: IO[str] | None = None
        self.records = 0
        self.failure: str | None = None
        """Why the last write or open failed; None while the log is writable."""

    def open(self) -> None:
        """Open (or create) the file now; AuditError saying why if it cannot be.

        Opening does not clear :attr:`failure`: a file opens for appending on a full disk too,
        where only the write fails. Only :meth:`ready`, by writing a record, clears it."""
        if self.path is None or self._file is not None:
            return
        try:
            self._file = self.path.open("a", encoding="utf-8")
        except OSError as exc:
            self.failure = f"{self.path}: {exc.strerror or exc}"
            raise AuditError(f"audit log {self.failure}") from exc

    def ready(self) -> None:
        """Raise AuditError unless records can be written. After a failure the file is reopened
        and a record saying so is written and flushed: the log counts as writable again only
        once a write has really reached the file (a full disk accepts the open, not the write),
        and the record marks the gap in the log."""
        if self.failure is None or self.path is None:
            return
        failure = self.failure
        self.close()
        self.open()
        text = self._entry(
            line="*",
            who="line server",
            face="-",
            what=f"audit log resumed after: {failure}",
            outcome="ok",
        )
        try:
            assert self._file is not None
            self._file.write(text + "\n")
            self._file.flush()
        except OSError as exc:
            self.failure = f"{self.path}: {exc.strerror or exc}"
            self.close()  # drops what is buffered: the next attempt starts from a clean file
            raise AuditError(f"audit log {self.failure}") from exc
        self.records += 1
        self.failure = None
        log.warning("audit log %s: written again (it failed: %s)", self.path, failure)

    @staticmethod
    def _entry(*, line: str, who: str, face: str, what: str, outcome: str) -> str:
        entry = {
            "at": round(time.time(), 6),
            "line": line,
            "who": who,
            "face": face,
            "what": what,
            "outcome": outcome,
        }
        return json.dumps(entry, ensure_ascii=False)

    def write(self, *, line: str, who: str, face: str, what: str, outcome: str) -> None:
        """Append one entry. Never raises: a failed write is logged with the whole entry and
        leaves :attr:`failure` set (see :meth:`ready`). Routine entries (a jog's keepalive that
        went through: :func:`audit_words.is_routine`) are not written."""
        if is_routine(what, outcome):
            return
        self.records += 1
        if self.path is None:
            return
        text = self._entry(line=line, who=who, face=face, what=what, outcome=outcome)
        try:
            self.open()
            assert self._file is not None
            self._file.write(text + "\n")
            self._file.flush()
        except (OSError, AuditError) as exc:
            if not isinstance(exc, AuditError):
                self.failure = f"{self.path}: {exc.strerror or exc}"
            log.error("audit log %s: this entry is not in it: %s", self.failure, text)

    def close(self) -> None:
        file, self._file = self._file, None
        if file is not None:
            with contextlib.suppress(OSError):
                file.close()
