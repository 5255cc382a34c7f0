"""Store and forward: while the broker is away, changes wait in a bounded SQLite file.

Rows keep their order (an autoincrement id); when the buffer is full the oldest rows go and
are counted (``dropped``), never silently. On reconnect the publisher takes rows in order,
publishes them marked historical, and deletes each batch only once it is out.
"""

from __future__ import annotations

import os
import sqlite3
import threading
from dataclasses import dataclass

__all__ = ["Buffered", "StoreAndForward"]


@dataclass(frozen=True)
class Buffered:
    id: int
    topic: str
    payload: bytes
    retain: bool


class StoreAndForward:
    """A bounded FIFO of (topic, payload) in SQLite (``path`` ``":memory:"`` for tests)."""

    def __init__(self, path: str | os.PathLike[str] = ":memory:", *, max_rows: int = 100_000):
        if max_rows < 1:
            raise ValueError("max_rows must be 1 or more")
        self.max_rows = max_rows
        self.dropped = 0
        """Changes lost to the bound (the oldest first)."""
        self._lock = threading.Lock()
        self._db = sqlite3.connect(os.fspath(path), check_same_thread=False, isolation_level=None)
        self._db.execute("PRAGMA journal_mode=WAL") if path != ":memory:" else None
        self._db.execute(
            "CREATE TABLE IF NOT EXISTS pending (id INTEGER PRIMARY KEY AUTOINCREMENT, "
            "topic TEXT NOT NULL, payload BLOB NOT NULL, retain INTEGER NOT NULL)"
        )
        self._count: int = int(self._db.execute("SELECT COUNT(*) FROM pending").fetchone()[0])

    def __len__(self) -> int:
        return self._count

    def put(self, topic: str, payload: bytes, retain: bool) -> None:
        with self._lock:
            self._db.execute(
                "INSERT INTO pending (topic, payload, retain) VALUES (?, ?, ?)",
                (topic, payload, int(retain)),
            )
            self._count += 1
            if self._count > self.max_rows:
                over = self._count - self.max_rows
                self._db.execute(
                    "DELETE FROM pending WHERE id IN (SELECT id FROM pending ORDER BY id LIMIT ?)",
                    (over,),
                )
                self._count -= over
                self.dropped += over

    def peek(self, n: int = 500) -> list[Buffered]:
        """The oldest ``n`` rows, in order (they stay until :meth:`remove`)."""
        with self._lock:
            rows = self._db.execute(
                "SELECT id, topic, payload, retain FROM pending ORDER BY id LIMIT ?", (n,)
            ).fetchall()
        return [Buffered(r[0], r[1], bytes(r[2]), bool(r[3])) for r in rows]

    def remove(self, upto_id: int) -> None:
        with self._lock:
            done = self._db.execute("DELETE FROM pending WHERE id <= ?", (upto_id,)).rowcount
            self._count -= max(0, done)

    def last_id(self) -> int | None:
        """The newest row's id (None: empty); a replay sends the rows up to it and no further."""
        with self._lock:
            row = self._db.execute("SELECT MAX(id) FROM pending").fetchone()
        return None if row is None or row[0] is None else int(row[0])

    def remove_ids(self, ids: list[int]) -> None:
        """Remove these rows (those a pipelined replay got acknowledged, whatever the order)."""
        with self._lock:
            before = self._db.total_changes
            self._db.executemany("DELETE FROM pending WHERE id = ?", [(i,) for i in ids])
            self._count -= max(0, self._db.total_changes - before)

    def close(self) -> None:
        with self._lock:
            self._db.close()
