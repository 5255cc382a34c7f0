"""The audit log: one JSON line per state-changing request (who, face, what, when, outcome)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import IO

__all__ = ["AuditLog"]


class AuditLog:
    """Appends to a JSONL file (or nowhere when ``path`` is None); flushed per record."""

    def __init__(self, path: str | Path | None) -> None:
        self.path = Path(path) if path is not None else None
        self._file: IO[str] | None = None
        self.records = 0

    def write(self, *, line: str, who: str, face: str, what: str, outcome: str) -> None:
        self.records += 1
        if self.path is None:
            return
        if self._file is None:
            self._file = self.path.open("a", encoding="utf-8")
        entry = {
            "at": round(time.time(), 6),
            "line": line,
            "who": who,
            "face": face,
            "what": what,
            "outcome": outcome,
        }
        self._file.write(json.dumps(entry, ensure_ascii=False) + "\n")
        self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
