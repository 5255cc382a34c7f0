"""The simulator's journal: the ground truth of what a virtual controller did, and when.

A :class:`Journal` takes one JSON object per line (JSONL): every state change the controller
carried out, with the time it happened on the simulator's own clock (the monotonic seconds its
driver passes in, as every other part of the simulator uses them). A test or a checker reads it
back (:func:`read_journal`) to know the controller's state at any instant:

``{"ev": "start", "t": ..., "ctrl": NAME, "speedup": S, "state": {...}}``
    A controller began (or began again, after a restart); ``state`` is all of it.
``{"ev": "cmd", "t": ..., "code": "GW", "cmd": {...}, "session": NAME, "result": R, "set": {...}}``
    A state-changing request was handled: ``result`` is ``done`` (carried out; a two-phase
    command's work may still follow), ``refused`` (with ``reason``; a refusal can still change
    state, an alarm) or ``upload`` (FB's file stored). ``set`` is what changed.
``{"ev": "change", "t": ..., "set": {...}}``
    The state changed by itself (a motion or a job step ended, a two-phase command's work
    finished) or from outside (an input contact, an alarm raised by a test).

``set`` maps state keys to their new values (``None`` for a key that is gone): ``status``
(the three AA bytes), ``alarms`` (``[code, channel]`` pairs, oldest first), ``in`` and ``out``
(one 16-bit number per port, contact 0 the lowest bit), ``int.I``, ``float.I``, ``point.C.I``
(``[axes, arm, used]``), ``file.C.NAME`` (a digest of the file as FA serves it, see
:func:`file_digest`) and per channel ``chC.speed``, ``chC.step``, ``chC.job``, ``chC.jog``,
``chC.joints`` (the joint values at rest; ``None`` while a path or a jog moves the robot) and
``chC.path``: the motion in progress as ``{"t0", "duration", "start", "end", "knots"}`` in real
seconds, the robot at ``start`` at ``t0`` and moving along the straight joint-space line to
``end`` (or through ``knots``, evenly spaced in time) until ``t0 + duration``. With it a
position at any instant is known: :func:`path_at`.

The journal is passive: the controller calls :class:`Observer` where it changes state; nothing
here touches a socket, a thread or a clock.
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
import json
import os
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from robostar.protocol.fields import FileName
from robostar.sim.filesystem import StoredJob, StoredPoints

if TYPE_CHECKING:
    from robostar.commands.base import Command
    from robostar.sim.model import Model
    from robostar.types import Point

__all__ = ["Journal", "Observer", "file_digest", "jsonable", "path_at", "read_journal"]

_WRITE_LOCK = threading.Lock()
"""One lock for every journal of the process: controllers on their own threads may share a file."""


def jsonable(value: Any) -> Any:
    """A command field (enums, file names, points, tuples) as plain JSON values."""
    if isinstance(value, enum.Enum):
        return value.name
    if isinstance(value, bool | int | float | str) or value is None:
        return value
    if isinstance(value, FileName):
        return str(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    return str(value)


def _point(point: Point) -> list[Any]:
    return [[round(a, 3) for a in point.axes], int(point.arm), point.used]


def file_digest(lines: Sequence[str] | None = None, points: dict[int, Point] | None = None) -> str:
    """A short digest of a file's content as FA serves it (in ANGLE coordinates): a job's
    lines, or a point file's used points. A checker computes it from a downloaded file."""
    if lines is not None:
        content: Any = ["job", list(lines)]
    else:
        content = ["pnt", [[n, *_point(p)] for n, p in sorted((points or {}).items())]]
    text = json.dumps(content, separators=(",", ":"))
    return hashlib.sha1(text.encode()).hexdigest()[:16]


def path_at(path: dict[str, Any], t: float) -> list[float]:
    """Joint values of a journaled ``chC.path`` at real time ``t``."""
    start, end, knots = path["start"], path["end"], path["knots"]
    duration = path["duration"]
    if duration <= 0 or t >= path["t0"] + duration:
        return list(end)
    s = max(0.0, (t - path["t0"]) / duration)
    points = knots or [start, end]
    spans = len(points) - 1
    i = min(int(s * spans), spans - 1)
    f = s * spans - i
    return [a + (b - a) * f for a, b in zip(points[i], points[i + 1], strict=True)]


class Journal:
    """Where the entries go: a JSONL file (appended to, one flushed line per entry) and/or a
    list in memory (``keep=True``, :attr:`entries`)."""

    def __init__(self, path: str | os.PathLike[str] | None = None, *, keep: bool = False):
        self.path = Path(path) if path is not None else None
        self.entries: list[dict[str, Any]] | None = [] if keep else None
        self._file: TextIO | None = (
            open(self.path, "a", encoding="utf-8")  # noqa: SIM115 - closed by close()
            if self.path is not None
            else None
        )

    def record(self, entry: dict[str, Any]) -> None:
        with _WRITE_LOCK:
            if self.entries is not None:
                self.entries.append(entry)
            if self._file is not None:
                self._file.write(json.dumps(entry, separators=(",", ":")) + "\n")
                self._file.flush()

    def close(self) -> None:
        with _WRITE_LOCK:
            if self._file is not None:
                self._file.close()
                self._file = None


def read_journal(path: str | os.PathLike[str]) -> Iterator[dict[str, Any]]:
    """The entries of a journal file, in the order they were written."""
    with open(path, encoding="utf-8") as file:
        for line in file:
            if line.strip():
                yield json.loads(line)


class Observer:
    """Watches one controller's model and writes what changed to a :class:`Journal`.

    ``observe(now)`` after time moved on (motion, jobs, timers, the outside world);
    ``command(...)`` after a state-changing request was handled. Globals and files are looked
    at only after commands: nothing else changes them.
    """

    def __init__(self, journal: Journal, model: Model, name: str):
        self.journal = journal
        self.model = model
        self.name = name
        self._state: dict[str, Any] = {}
        self._slow: dict[str, Any] = {}

    def start(self, now: float) -> None:
        self._state = self._fast(now)
        self._slow = self._slow_state()
        self.journal.record(
            {
                "ev": "start",
                "t": now,
                "ctrl": self.name,
                "speedup": self.model.config.speedup,
                "state": {**self._state, **self._slow},
            }
        )

    def observe(self, now: float) -> None:
        changes = self._diff(self._state, self._fast(now))
        if changes:
            self.journal.record({"ev": "change", "t": now, "ctrl": self.name, "set": changes})

    def command(
        self,
        now: float,
        session: str,
        command: Command[Any],
        result: str,
        reason: str | None = None,
    ) -> None:
        changes = self._diff(self._state, self._fast(now))
        changes.update(self._diff(self._slow, self._slow_state()))
        entry: dict[str, Any] = {
            "ev": "cmd",
            "t": now,
            "ctrl": self.name,
            "code": command.CODE,
            "cmd": jsonable(command),
            "session": session,
            "result": result,
            "set": changes,
        }
        if reason is not None:
            entry["reason"] = reason
        self.journal.record(entry)

    @staticmethod
    def _diff(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
        changes = {k: v for k, v in new.items() if k not in old or old[k] != v}
        changes.update({k: None for k in old if k not in new})
        old.clear()
        old.update(new)
        return changes

    def _fast(self, now: float) -> dict[str, Any]:
        """What can change by itself: status, alarms, I/O, motion, jobs."""
        model = self.model
        speedup = model.config.speedup
        state: dict[str, Any] = {
            "status": [s.to_byte() for s in model.status()],
            "alarms": [[e.code, e.channel] for e in model.alarms.current],
            "in": [_bits(port) for port in model.inputs],
            "out": [_bits(port) for port in model.outputs],
        }
        for ch in model.channels:
            key = f"ch{ch.number}"
            state[f"{key}.speed"] = ch.speed
            state[f"{key}.step"] = ch.job.step if ch.job is not None else 0
            state[f"{key}.job"] = str(ch.job_name) if ch.job_name is not None else None
            state[f"{key}.jog"] = ch.jog is not None
            path = ch.path
            if path is None:
                state[f"{key}.path"] = None
                state[f"{key}.joints"] = None if ch.jog is not None else list(ch.joints)
            else:
                state[f"{key}.joints"] = None
                state[f"{key}.path"] = {
                    "t0": now - ch.path_t / speedup,
                    "duration": path.duration / speedup,
                    "start": list(path.start),
                    "end": list(path.end),
                    "knots": [list(k) for k in path.knots] or None,
                }
        return state

    def _slow_state(self) -> dict[str, Any]:
        """What only commands change: globals and files."""
        model = self.model
        state: dict[str, Any] = {}
        for index, value in model.ints.items():
            state[f"int.{index}"] = value
        for index, number in model.floats.items():
            state[f"float.{index}"] = number
        for ch in model.channels:
            for index, point in ch.points.items():
                state[f"point.{ch.number}.{index}"] = _point(point)
            for stored in ch.files:
                if isinstance(stored, StoredJob):
                    digest = file_digest(lines=stored.lines)
                elif isinstance(stored, StoredPoints):
                    digest = file_digest(points=stored.points)
                else:  # pragma: no cover - the two kinds above are all there is
                    continue
                state[f"file.{ch.number}.{stored.name}"] = digest
        return state


def _bits(contacts: Sequence[bool]) -> int:
    return sum(1 << i for i, on in enumerate(contacts) if on)
