"""The audit log's entries as a person reads them: a command's name and fields with units, enums
and file names as written rather than Python's reprs (``<JogDirection.PLUS: 1>``,
``FileName(stem=...)``), and a file write as its name, size and hash instead of its whole text
(the text is kept by the program version store, serve/programs.py, under that hash).

:func:`describe` is what the line records for a command; :func:`is_routine` says which entries
are not written at all: a jog's keepalive (BF, five a second while an axis jogs) that went
through, whose start and stop are recorded.
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
from typing import Any

from robostar.commands.base import Command
from robostar.commands.control import SetSpeed
from robostar.commands.files import UploadFile
from robostar.commands.motion import JogContinue, Move, MoveBy
from robostar.protocol.fields import FileName
from robostar.types import CoordSystem

__all__ = ["KEEPALIVE", "describe", "is_routine", "text_hash"]

KEEPALIVE = "jog keepalive"
"""How a jog's keepalive (BF) is described: routine when it went through."""
_LIMIT = 300


def text_hash(lines: tuple[str, ...] | list[str]) -> str:
    """The SHA-256 of a file's text as the version store keeps it (lines ended by newlines)."""
    text = "".join(f"{line}\n" for line in lines)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _axes(values: tuple[float, ...]) -> str:
    return "(" + ", ".join(f"{v:+.3f}" if v else "0" for v in values) + ")"


def describe(command: Command[Any]) -> str:
    """What ``command`` asks of the controller: its name and fields in words and units
    (``SetSpeed(channel=1, speed=37.5 %)``); enums by name, files by name, a file's text as its
    line count, size and hash. The name leads, so an entry is found by the command's name."""
    name = type(command).__name__
    match command:
        case JogContinue(channel=ch):
            return f"{KEEPALIVE}: channel {ch}"
        case SetSpeed(channel=ch, speed=speed):
            return f"{name}(channel={ch}, speed={speed / 10:g} %)"
        case MoveBy(channel=ch, motion=motion, coords=coords, delta=delta):
            unit = "mm/°" if coords is CoordSystem.XY else "°/mm"
            return (
                f"{name}(channel={ch}, motion={motion.name}, coords={coords.name},"
                f" delta={_axes(delta)} {unit})"
            )
        case Move(channel=ch, motion=motion, coords=coords, points=points):
            shown = ", ".join(_axes(p) for p in points)
            return f"{name}(channel={ch}, motion={motion.name}, coords={coords.name}, to={shown})"
        case UploadFile(channel=ch, file=file, job_number=number, lines=lines):
            size = sum(len(line) + 1 for line in lines)
            return (
                f"{name}(channel={ch}, file={file}, job_number={number}: {len(lines)} lines,"
                f" {size} bytes, sha256 {text_hash(lines)[:16]})"
            )
    return f"{name}({_fields(command)})"[:_LIMIT]


def _fields(command: Command[Any]) -> str:
    """A command's fields as ``name=value``, enums by name and file names as written."""
    if not dataclasses.is_dataclass(command):
        return ""
    parts = []
    for field in dataclasses.fields(command):
        value = getattr(command, field.name)
        parts.append(f"{field.name}={_value(value)}")
    return ", ".join(parts)


def _value(value: object) -> str:
    if isinstance(value, enum.Enum):
        return value.name
    if isinstance(value, FileName):
        return str(value)
    if isinstance(value, tuple) and len(value) > 8:
        return f"({len(value)} items)"
    return str(value)


def is_routine(what: str, outcome: str) -> bool:
    """An entry not written: a jog keepalive that went through."""
    return outcome == "ok" and what.startswith((KEEPALIVE, "JogContinue("))
