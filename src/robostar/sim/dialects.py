"""Dialects: the ways a real controller may write what the manual allows, for the simulator.

robostar reads answers tolerantly (docs/protocol.md, "Field encoding"), and a simulator that
only ever speaks robostar's own reading cannot show that it does. A dialect rewrites the
simulator's answer packets, after its commands encode them, into another form the manual
allows. Select one with ``robostar sim --dialect NAME``, ``sim://?dialect=NAME`` or
``SimConfig(dialect=NAME)``.

``manual``
    The default: what robostar itself sends (right-aligned coordinates, 9-byte GR floats when
    they fit, FA's first packet the count of lines, DB's wait as two digits).
``capacity``
    FA's first packet is the controller's capacity, ``2000``, not the file's length (the
    manual's own example; an independent N1 implementation does this).
``left-aligned``
    Coordinates left-aligned with trailing spaces, as the manual's drawing shows
    (``"12345.123 "``), in AC, GR (points and floats) and FA's point lines.
``padded``
    Numbers zero-padded with an explicit sign (``"+00123.450"``), GR floats always in GW's 10
    bytes, FA's first packet and DB/DC's announced wait padded with spaces (``"   3"``, ``" 2"``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from robostar.commands.base import Command
from robostar.commands.files import DownloadFile
from robostar.commands.job import SelectJob, Servo
from robostar.commands.status import ReadPosition
from robostar.commands.variables import ReadGlobalFloat, ReadGlobalPoint
from robostar.errors import UsageError
from robostar.types import PositionKind

__all__ = ["DIALECTS", "Dialect", "dialect_named"]

COORD = 10
POINT_AXIS = 11
_CAPACITY = b"2000"

Chunk = Callable[[bytes], bytes]
"""Rewrites one number field, keeping its width."""


def _left(chunk: bytes) -> bytes:
    return chunk.strip().ljust(len(chunk))


def _signed_zero_padded(chunk: bytes) -> bytes:
    value = float(chunk.strip())
    return f"{value:+0{len(chunk)}.3f}".encode("ascii")


def _spaced_int(chunk: bytes) -> bytes:
    return str(int(chunk.strip())).rjust(len(chunk)).encode("ascii")


def _split(packet: bytes) -> tuple[bytes, bytes]:
    """(head: [FF] FLAG, body)."""
    cut = 2 if packet[:1] == b"\xff" else 1
    return packet[:cut], packet[cut:]


def _fields(body: bytes, start: int, count: int, width: int, chunk: Chunk) -> bytes:
    end = start + count * width
    parts = [chunk(body[i : i + width]) for i in range(start, end, width)]
    return body[:start] + b"".join(parts) + body[end:]


@dataclass(frozen=True)
class Dialect:
    """A named set of rewrites of answer packets (see the module's docstring)."""

    name: str
    summary: str
    coords: Chunk | None = None
    """Rewrites every coordinate field of AC, GR and FA point lines."""
    wide_float: bool = False
    """GR's float always in GW's 10 bytes."""
    fa_first: Callable[[bytes], bytes] | None = None
    """Rewrites FA's first packet's body (the 4-digit figure)."""
    wait: Chunk | None = None
    """Rewrites DB/DC's announced wait (2 digits)."""

    @property
    def plain(self) -> bool:
        """No rewrite at all (the manual's own format): :meth:`dress` returns the packets."""
        return (
            self.coords is None
            and self.wait is None
            and self.fa_first is None
            and not self.wide_float
        )

    def dress(self, command: Command[Any], packets: Sequence[bytes]) -> list[bytes]:
        """The answer packets as this dialect writes them."""
        out = list(packets)
        if not out or self.plain:
            return out
        if isinstance(command, DownloadFile):
            return self._download(out)
        head, body = _split(out[0])
        if head[-1:] != b"0":
            return out  # an error flag: nothing to rewrite
        if isinstance(command, ReadPosition) and command.kind is not PositionKind.PULSE:
            if self.coords is not None:
                axes = (len(body) - 1) // COORD
                out[0] = head + _fields(body, 0, axes, COORD, self.coords)
        elif isinstance(command, ReadGlobalFloat):
            if self.wide_float:
                body = body.strip().rjust(COORD)
            if self.coords is not None:
                body = self.coords(body)
            out[0] = head + body
        elif isinstance(command, ReadGlobalPoint):
            if self.coords is not None:
                axes = (len(body) - 2) // COORD  # the type byte, the axes, USED
                out[0] = head + _fields(body, 1, axes, COORD, self.coords)
        elif isinstance(command, Servo | SelectJob) and self.wait is not None:
            out[0] = head + self.wait(body)
        return out

    def _download(self, packets: list[bytes]) -> list[bytes]:
        head, body = _split(packets[0])
        if self.fa_first is not None and head[-1:] == b"0":
            packets[0] = head + self.fa_first(body)
        if self.coords is not None:
            for i, packet in enumerate(packets[1:], 1):
                head, body = _split(packet)
                if body[:1] == b"P" and len(body) > 5 + POINT_AXIS:
                    axes = (len(body) - 5 - 3) // POINT_AXIS  # P+4 digits, ARM, USED, newline
                    packets[i] = head + _fields(body, 5, axes, POINT_AXIS, self.coords)
        return packets


DIALECTS: dict[str, Dialect] = {
    d.name: d
    for d in (
        Dialect("manual", "what robostar sends: the manual as docs/protocol.md reads it"),
        Dialect(
            "capacity",
            "FA's first packet is the controller's capacity (2000), not the file's length",
            fa_first=lambda body: _CAPACITY,
        ),
        Dialect(
            "left-aligned",
            "coordinates left-aligned with trailing spaces, as the manual's drawing",
            coords=_left,
        ),
        Dialect(
            "padded",
            "numbers zero-padded with a sign, GR floats in 10 bytes, integers space-padded",
            coords=_signed_zero_padded,
            wide_float=True,
            fa_first=_spaced_int,
            wait=_spaced_int,
        ),
    )
}
"""Every dialect by name."""


def dialect_named(name: str) -> Dialect:
    """The dialect called ``name``; UsageError listing the names for any other."""
    try:
        return DIALECTS[name]
    except KeyError:
        raise UsageError(f"dialect: {name!r} is not one of {', '.join(DIALECTS)}") from None
