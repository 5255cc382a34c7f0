"""Programs under change control: every JOB and PNT file the server writes to a controller or
reads from it, kept as a version, with who and when.

A version is the file's text (its lines as FB sends and FA returns them, each ended by a newline)
stored once by its SHA-256 (content-addressed: the same text is kept once, whatever the number of
files and versions that hold it), and an entry in the file's history: when, who, through which
face, how (``upload``, ``download``, ``backup``, ``restore``, ``check``), the size in bytes and
the hash. A new version is added only when the text differs from the file's last one: reading a
file a hundred times is one version. Each file keeps its last ``retention`` versions; a text no
version holds any more is deleted.

On disk (``root``): ``blobs/ab/abcdef...`` (the texts) and ``history/LINE/chN/NAME.jsonl`` (one
JSON line per version, oldest first). Without a root the store lives in memory (tests, a server
without a state folder). Entries are appended and flushed one by one; the history of a file is
rewritten (to a temporary file, then renamed) only to drop versions past the retention.

:func:`check` compares what a controller holds now (its listing and each file's hash) with the
last versions: a file changed, added or removed at the pendant shows up, and its current text is
kept as a version ("check").
"""

from __future__ import annotations

import contextlib
import difflib
import hashlib
import json
import os
import tempfile
import time
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from pathlib import Path

from robostar.client.files import point_lines
from robostar.commands.files import DownloadFile, ListFiles
from robostar.errors import UsageError
from robostar.protocol.fields import FileName
from robostar.serve.lease import Who
from robostar.serve.line import Line
from robostar.types import CoordSystem, JobFile, PointFile

__all__ = [
    "DEFAULT_RETENTION",
    "Drift",
    "ProgramStore",
    "Version",
    "check",
    "diff_lines",
    "program_text",
]

DEFAULT_RETENTION = 50
"""Versions kept per file unless configured otherwise."""
HOWS = frozenset(("upload", "download", "backup", "restore", "check", "point edit", "teach here"))


@dataclass(frozen=True, slots=True)
class Version:
    """One version of one file: its text's hash and size, and who made or saw it when, how."""

    hash: str
    size: int
    at: float
    who: str
    face: str
    how: str

    @property
    def short(self) -> str:
        return self.hash[:10]


def program_text(content: JobFile | PointFile) -> str:
    """A file's text as kept: its lines (a PNT file's as FB sends them), each ended by ``\\n``."""
    if isinstance(content, JobFile):
        lines: Iterable[str] = content.lines
    else:
        lines = point_lines(content)
    return "".join(f"{line}\n" for line in lines)


def text_of_lines(lines: Iterable[str]) -> str:
    return "".join(f"{line}\n" for line in lines)


def _hash(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _safe(part: str) -> str:
    if not part or any(c in part for c in "/\\\0") or part in (".", ".."):
        raise UsageError(f"programs: {part!r} cannot name a folder")
    return part


class ProgramStore:
    """The versions of every file of every line (see the module docstring)."""

    def __init__(self, root: str | Path | None, retention: int = DEFAULT_RETENTION) -> None:
        if isinstance(retention, bool) or not isinstance(retention, int) or retention < 1:
            raise UsageError(f"programs: retention {retention!r} is not a whole number >= 1")
        self.root = Path(root) if root is not None else None
        self.retention = retention
        self._blobs: dict[str, str] = {}
        self._histories: dict[tuple[str, int, str], list[Version]] = {}

    # -- writing -----------------------------------------------------------------------------
    def record(
        self, line: str, channel: int, name: FileName | str, text: str, who: Who, how: str
    ) -> Version | None:
        """Keep ``text`` as the file's new version; None if it is the file's last one already."""
        if how not in HOWS:
            raise UsageError(f"programs: how {how!r} is not one of {', '.join(sorted(HOWS))}")
        file = str(name).upper()
        history = self.versions(line, channel, file)
        digest = _hash(text)
        if history and history[0].hash == digest:
            return None
        version = Version(
            digest, len(text.encode("utf-8")), round(time.time(), 3), who.name, who.face, how
        )
        self._put_blob(digest, text)
        self._append(line, channel, file, version)
        if len(history) + 1 > self.retention:
            self._prune(line, channel, file)
        return version

    def _put_blob(self, digest: str, text: str) -> None:
        if self.root is None:
            self._blobs[digest] = text
            return
        path = self._blob_path(digest)
        if path.exists():
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        _write_atomic(path, text.encode("utf-8"))

    def _append(self, line: str, channel: int, file: str, version: Version) -> None:
        if self.root is None:
            self._histories.setdefault((line, channel, file), []).append(version)
            return
        path = self._history_path(line, channel, file)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("a", encoding="utf-8") as handle:
            handle.write(json.dumps(asdict(version)) + "\n")
            handle.flush()

    def _prune(self, line: str, channel: int, file: str) -> None:
        oldest_first = list(reversed(self.versions(line, channel, file)))
        dropped, kept = oldest_first[: -self.retention], oldest_first[-self.retention :]
        if self.root is None:
            self._histories[(line, channel, file)] = kept
        else:
            text = "".join(json.dumps(asdict(v)) + "\n" for v in kept)
            _write_atomic(self._history_path(line, channel, file), text.encode("utf-8"))
        held = self._all_hashes()
        for version in dropped:
            if version.hash not in held:
                if self.root is None:
                    self._blobs.pop(version.hash, None)
                else:
                    with contextlib.suppress(FileNotFoundError):
                        self._blob_path(version.hash).unlink()

    def _all_hashes(self) -> set[str]:
        if self.root is None:
            return {v.hash for history in self._histories.values() for v in history}
        found: set[str] = set()
        for path in (self.root / "history").rglob("*.jsonl"):
            found |= {v.hash for v in _read_history(path)}
        return found

    # -- reading -----------------------------------------------------------------------------
    def versions(self, line: str, channel: int, name: FileName | str) -> list[Version]:
        """The file's versions, newest first."""
        file = str(name).upper()
        if self.root is None:
            return list(reversed(self._histories.get((line, channel, file), [])))
        return list(reversed(_read_history(self._history_path(line, channel, file))))

    def latest(self, line: str, channel: int, name: FileName | str) -> Version | None:
        history = self.versions(line, channel, name)
        return history[0] if history else None

    def find(self, line: str, channel: int, name: FileName | str, ref: str) -> Version:
        """A version by its number (1 = the oldest kept, -1 = the newest) or a hash prefix."""
        history = list(reversed(self.versions(line, channel, name)))
        if not history:
            raise UsageError(f"{name}: no versions kept for line {line} channel {channel}")
        text = ref.strip().lower()
        if text.lstrip("-").isdigit():
            index = int(text)
            if index == 0 or abs(index) > len(history):
                raise UsageError(f"{name}: versions run 1-{len(history)}, not {ref}")
            return history[index - 1 if index > 0 else index]
        found = [v for v in history if v.hash.startswith(text)] if len(text) >= 4 else []
        if len(found) != 1:
            raise UsageError(f"{name}: no single version's hash starts with {ref!r}")
        return found[0]

    def text(self, digest: str) -> str:
        if self.root is None:
            if digest not in self._blobs:
                raise UsageError(f"programs: no text kept with hash {digest[:10]}")
            return self._blobs[digest]
        try:
            return self._blob_path(digest).read_text(encoding="utf-8")
        except FileNotFoundError:
            raise UsageError(f"programs: no text kept with hash {digest[:10]}") from None

    def lines(self) -> list[str]:
        """The lines with versions kept."""
        if self.root is None:
            return sorted({ln for (ln, _, _) in self._histories})
        base = self.root / "history"
        return sorted(p.name for p in base.iterdir() if p.is_dir()) if base.is_dir() else []

    def files(self, line: str) -> list[tuple[int, str]]:
        """The (channel, name) of every file of the line with versions kept."""
        if self.root is None:
            return sorted((ch, name) for (ln, ch, name) in self._histories if ln == line)
        base = self.root / "history" / _safe(line)
        return sorted(
            (int(path.parent.name[2:]), path.stem)
            for path in base.glob("ch*/*.jsonl")
            if path.parent.name[2:].isdigit()
        )

    # -- paths -------------------------------------------------------------------------------
    def _blob_path(self, digest: str) -> Path:
        assert self.root is not None
        if len(digest) != 64 or any(c not in "0123456789abcdef" for c in digest):
            raise UsageError(f"programs: {digest!r} is not a SHA-256")
        return self.root / "blobs" / digest[:2] / digest

    def _history_path(self, line: str, channel: int, file: str) -> Path:
        assert self.root is not None
        return self.root / "history" / _safe(line) / f"ch{channel}" / f"{_safe(file)}.jsonl"


def _read_history(path: Path) -> list[Version]:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return []
    found = []
    for row in text.splitlines():
        with contextlib.suppress(ValueError, TypeError, KeyError):
            found.append(Version(**json.loads(row)))
    return found


def _write_atomic(target: Path, data: bytes) -> None:
    fd, temporary = tempfile.mkstemp(prefix=f".{target.name}.", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as stream:
            stream.write(data)
        os.replace(temporary, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def diff_lines(old: str, new: str, old_label: str, new_label: str) -> list[str]:
    """A line-by-line (unified) diff of two texts; empty when they are the same."""
    return list(
        difflib.unified_diff(
            old.splitlines(), new.splitlines(), old_label, new_label, lineterm="", n=3
        )
    )


@dataclass(frozen=True, slots=True)
class Drift:
    """One file in a check: ``state`` is "same", "changed" (not through the server), "new"
    (never seen by the server), or "gone" (kept here, not on the controller)."""

    channel: int
    name: str
    state: str
    hash: str | None
    last: Version | None


async def check(store: ProgramStore, line: Line, channels: Iterable[int], who: Who) -> list[Drift]:
    """Compare what the controller holds now with the last versions kept (FD, then FA for each
    file); a file changed or added at the pendant is kept as a version ("check")."""
    found: list[Drift] = []
    for channel in channels:
        records = await line.read(ListFiles(channel, "*"), max_age=0)
        seen = set()
        for record in records:
            name = FileName.parse(record.name)
            seen.add(str(name).upper())
            content = await line.read(DownloadFile(channel, name, CoordSystem.ANGLE), max_age=0)
            text = program_text(content)
            last = store.latest(line.name, channel, name)
            digest = _hash(text)
            if last is None:
                state = "new"
            elif last.hash == digest:
                state = "same"
            else:
                state = "changed"
            if state != "same":
                store.record(line.name, channel, name, text, who, "check")
            found.append(Drift(channel, str(name), state, digest, last))
        for kept_channel, kept in store.files(line.name):
            if kept_channel == channel and kept not in seen:
                last = store.latest(line.name, channel, kept)
                found.append(Drift(channel, kept, "gone", None, last))
    return found
