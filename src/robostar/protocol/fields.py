"""Field codecs: fixed-width numbers, codes, coordinates, names and bit bytes, with range checks.

Encoders check the manual's limits and raise :class:`~robostar.errors.FieldError` naming the
field before any byte is produced. Decoders accept either space or zero padding (as
PROTOCOL-NOTES asks of receivers) and raise the same error, whose ``flag`` is what a controller
answers for that fault. :class:`Reader` walks a packet's fields in order.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypeVar, cast

from robostar.errors import FieldError
from robostar.types import ChannelStatus

__all__ = [
    "COORD_WIDTH",
    "FLAG_END",
    "FLAG_FAILED",
    "FLAG_OK",
    "FLAG_REJECTED",
    "FLAG_UNSUPPORTED",
    "FileName",
    "NameProblem",
    "Reader",
    "check_channel",
    "check_range",
    "decode_io_nibbles",
    "decode_using_axes",
    "encode_channel",
    "encode_code",
    "encode_coord",
    "encode_int",
    "encode_io_nibbles",
    "encode_pulse",
    "encode_text",
    "encode_using_axes",
    "parse_coord",
    "parse_int",
]

FLAG_OK = 0x30
FLAG_REJECTED = 0x31
FLAG_FAILED = 0x32
FLAG_UNSUPPORTED = 0x33
FLAG_END = 0x34

COORD_WIDTH = 10
_E = TypeVar("_E", bound=enum.IntEnum)


def check_range(
    command: str, field: str, value: int, lo: int, hi: int, *, flag: int = FLAG_REJECTED
) -> int:
    """``value`` if it is an int in ``lo..hi``, else a FieldError naming the field."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise FieldError(
            command, field, f"must be an integer, not {type(value).__name__}", flag=flag
        )
    if not lo <= value <= hi:
        raise FieldError(command, field, f"{value} is out of range {lo}..{hi}", flag=flag)
    return value


def check_channel(command: str, channel: int, field: str = "channel") -> int:
    """A pendant channel number, 1-3."""
    return check_range(command, field, channel, 1, 3)


def encode_code(command: str, field: str, value: int, lo: int, hi: int) -> bytes:
    """A one-byte ASCII digit code (``0`` -> ``b"0"``); an IntEnum member is its value."""
    return b"%d" % check_range(command, field, value, lo, hi)


def encode_channel(command: str, channel: int, field: str = "channel") -> bytes:
    """Pendant channel 1-3 as the wire's ``'0'..'2'``."""
    return b"%d" % (check_channel(command, channel, field) - 1)


def encode_int(
    command: str,
    field: str,
    value: int,
    width: int,
    *,
    lo: int | None = None,
    hi: int | None = None,
    pad: str = "0",
) -> bytes:
    """A right-aligned integer in exactly ``width`` bytes, zero- or space-padded."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise FieldError(command, field, f"must be an integer, not {type(value).__name__}")
    if lo is not None and hi is not None:
        check_range(command, field, value, lo, hi)
    text = f"{value:0{width}d}" if pad == "0" and value >= 0 else f"{value:>{width}d}"
    if len(text) > width:
        raise FieldError(command, field, f"{value} does not fit in {width} bytes")
    return text.encode("ascii")


COORD_RESOLUTION = 0.001
"""A coordinate field's step: 3 decimals (mm, degrees)."""


def encode_coord(
    command: str, field: str, value: float, width: int = COORD_WIDTH, *, exact: bool = False
) -> bytes:
    """A coordinate with 3 decimals, right-aligned and space-padded (``"  -123.450"``).

    ``exact`` (a request's value, as the caller gave it): a value finer than the field's
    0.001 is refused rather than rounded, so what is sent is what was asked. Answers (a
    controller's computed positions) are rounded to the field."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FieldError(command, field, f"must be a number, not {type(value).__name__}")
    if value != value or value in (float("inf"), float("-inf")):
        raise FieldError(command, field, f"{value} is not a finite number")
    if exact:
        steps = value / COORD_RESOLUTION
        # Binary floats: 12.345 is 12344.999999999998 steps; allow that, not 0.0004's 0.4.
        if abs(steps - round(steps)) > max(1e-9, abs(steps) * 1e-12):
            raise FieldError(
                command,
                field,
                f"{value!r} is finer than the field's resolution of {COORD_RESOLUTION} "
                "(3 decimals): round it first",
            )
    text = f"{value:>{width}.3f}"
    if text.strip() == "-0.000":
        text = f"{0.0:>{width}.3f}"
    if len(text) > width:
        raise FieldError(command, field, f"{value} does not fit in {width} bytes with 3 decimals")
    return text.encode("ascii")


def encode_pulse(command: str, field: str, value: int, width: int = COORD_WIDTH) -> bytes:
    """A pulse count, integer, right-aligned and space-padded."""
    return encode_int(command, field, value, width, pad=" ")


def encode_text(command: str, field: str, text: str, width: int, *, align: str = "<") -> bytes:
    """ASCII text in exactly ``width`` bytes, padded with spaces (``<`` left, ``>`` right)."""
    try:
        raw = text.encode("ascii")
    except UnicodeEncodeError:
        raise FieldError(command, field, f"{text!r} is not ASCII") from None
    if len(raw) > width:
        raise FieldError(command, field, f"{text!r} is longer than {width} bytes")
    if any(b < 0x20 and b not in (0x09, 0x0A) for b in raw):
        raise FieldError(command, field, f"{text!r} holds control characters")
    return raw.ljust(width) if align == "<" else raw.rjust(width)


_INT_TEXT = re.compile(r"[+-]?\d+")
_COORD_TEXT = re.compile(r"[+-]?(\d+(\.\d{0,3})?|\.\d{1,3})")


def parse_int(command: str, field: str, raw: bytes, *, flag: int = FLAG_REJECTED) -> int:
    """An integer field, space- or zero-padded."""
    text = raw.decode("ascii", "replace").strip()
    if not _INT_TEXT.fullmatch(text):
        raise FieldError(command, field, f"{raw!r} is not an integer", flag=flag)
    return int(text)


def parse_coord(command: str, field: str, raw: bytes, *, fixed: bool = True) -> float:
    """A coordinate field: spaces on either side, leading zeros, an explicit sign and up to 3
    decimals are all read. ``fixed`` (a field of set width): the value written with 3 decimals
    must fit the width, as a sender could have sent it; a free-width field (GR's float, the
    rest of its answer) takes whatever width the number has."""
    text = raw.decode("ascii", "replace").strip()
    if not _COORD_TEXT.fullmatch(text):
        raise FieldError(command, field, f"{raw!r} is not a number with up to 3 decimals")
    value = float(text)
    if fixed and len(f"{value:.3f}") > len(raw):
        raise FieldError(command, field, f"{raw!r} does not fit {len(raw)} bytes with 3 decimals")
    return value


def encode_using_axes(command: str, axes: Sequence[int]) -> bytes:
    """AD's using-axis byte: ``0x40 | mask`` with bit0 = axis 1."""
    mask = 0
    for axis in axes:
        mask |= 1 << (check_range(command, "axes in use", axis, 1, 6) - 1)
    return bytes((0x40 | mask,))


def decode_using_axes(command: str, byte: int) -> tuple[int, ...]:
    if byte & 0xC0 != 0x40:
        raise FieldError(command, "axes in use", f"byte 0x{byte:02X} lacks the 0x40 marker")
    return tuple(axis for axis in range(1, 7) if byte & (1 << (axis - 1)))


def encode_io_nibbles(contacts: Sequence[bool]) -> bytes:
    """16 contacts as four ``0x30 | nibble`` bytes; contact 0 is the first byte's 0x8 bit."""
    if len(contacts) != 16:
        raise FieldError("", "contacts", f"need 16 contacts, got {len(contacts)}")
    out = bytearray()
    for group in range(4):
        nibble = 0
        for bit in range(4):
            if contacts[group * 4 + bit]:
                nibble |= 0x8 >> bit
        out.append(0x30 | nibble)
    return bytes(out)


def decode_io_nibbles(command: str, raw: bytes) -> tuple[bool, ...]:
    if len(raw) != 4 or any(b & 0xF0 != 0x30 for b in raw):
        raise FieldError(command, "contact states", f"{raw!r} is not four 0x3N bytes")
    return tuple(bool(raw[i // 4] & (0x8 >> (i % 4))) for i in range(16))


class NameProblem(enum.Enum):
    EMPTY = "the name is empty"
    TOO_LONG = "the name has more than 5 characters"
    MIXED_CASE = "the name mixes upper and lower case"
    BAD_CHARACTER = "the name may hold only letters, digits and _"
    BAD_EXTENSION = "the extension must be JOB or PNT (or job or pnt)"
    NO_EXTENSION = "the name needs an extension, .JOB or .PNT"


_NAME_CHARS = re.compile(r"[A-Za-z0-9_]+")


@dataclass(frozen=True, slots=True)
class FileName:
    """A controller file name: a stem of up to 5 characters in one case, and JOB or PNT.

    ``parse`` accepts anything a peer might send (spaces removed) and keeps it as it is;
    ``problem()`` says what breaks the manual's name rules, so a host can refuse it before
    sending and a controller can answer with the flag the manual names.
    """

    stem: str
    extension: str

    @classmethod
    def exact(cls, text: str, command: str = "", field: str = "file name") -> FileName:
        """``text`` as a FileName, as the caller wrote it: a name that the wire would change
        (spaces, NUL and other control characters, which :meth:`parse` drops from a padded
        field) is refused with the rule, never silently changed."""
        name = cls.parse(text)
        if str(name) != text or any(c.isspace() or not c.isprintable() for c in text):
            raise FieldError(
                command or "-",
                field,
                f"{text!r}: a name may hold only letters, digits and _ and one dot "
                "(no spaces or control characters)",
            )
        return name

    @classmethod
    def parse(cls, text: str) -> FileName:
        """A name read from a field: padding spaces and NUL bytes are dropped."""
        text = text.replace(" ", "").replace("\x00", "")
        stem, dot, ext = text.rpartition(".")
        if not dot:
            return cls(text, "")
        return cls(stem, ext)

    def __str__(self) -> str:
        return f"{self.stem}.{self.extension}" if self.extension else self.stem

    @property
    def is_job(self) -> bool:
        return self.extension.upper() == "JOB"

    @property
    def is_points(self) -> bool:
        return self.extension.upper() == "PNT"

    @property
    def key(self) -> str:
        """Case-folded name, for lookups: ``RS.JOB`` and ``rs.job`` are different files on the
        controller only in case, and the manual forbids mixing, so a store can key on this."""
        return str(self).upper()

    def problem(self) -> NameProblem | None:
        if not self.stem:
            return NameProblem.EMPTY
        if len(self.stem) > 5:
            return NameProblem.TOO_LONG
        if not _NAME_CHARS.fullmatch(self.stem):
            return NameProblem.BAD_CHARACTER
        if not self.extension:
            return NameProblem.NO_EXTENSION
        if self.extension not in ("JOB", "PNT", "job", "pnt"):
            return NameProblem.BAD_EXTENSION
        letters = [c for c in self.stem if c.isalpha()]
        if letters and not (all(c.isupper() for c in letters) or all(c.islower() for c in letters)):
            return NameProblem.MIXED_CASE
        return None

    def check(
        self,
        command: str,
        field: str = "file name",
        *,
        kind: str | None = None,
        case_flag: int = FLAG_FAILED,
    ) -> FileName:
        """Raise FieldError if the name breaks the rules; ``kind`` "JOB"/"PNT" restricts it.

        Flags as the manual gives them: a name over 5 characters is 0x32; mixed case or a
        wrong extension is ``case_flag`` (0x31 for BB and DC, 0x32 elsewhere).
        """
        problem = self.problem()
        if problem is None and kind is not None and self.extension.upper() != kind:
            raise FieldError(command, field, f"{self}: must be a .{kind} file", flag=case_flag)
        if problem is None:
            return self
        flag = FLAG_FAILED if problem is NameProblem.TOO_LONG else case_flag
        raise FieldError(command, field, f"{self}: {problem.value}", flag=flag)

    def encode(self, command: str, field: str, width: int = 12, *, align: str = ">") -> bytes:
        return encode_text(command, field, str(self), width, align=align)


_ENUM_VALUES: dict[type[enum.IntEnum], tuple[int, int, dict[int, enum.IntEnum]]] = {}
"""The lowest and highest value of each IntEnum a Reader has read, and its members by value
(``kind(value)`` without the enum machinery; enums are fixed)."""


class Reader:
    """Reads a request's or answer's fields in order, naming each one in its errors."""

    __slots__ = ("command", "data", "pos")

    def __init__(self, command: str, data: bytes, pos: int = 0):
        self.command = command
        self.data = data
        self.pos = pos

    @property
    def remaining(self) -> int:
        return len(self.data) - self.pos

    def take(self, n: int, field: str) -> bytes:
        pos = self.pos
        end = pos + n
        data = self.data
        if end > len(data):
            raise FieldError(
                self.command,
                field,
                f"needs {n} bytes, only {self.remaining} left",
            )
        self.pos = end
        return data[pos:end]

    def rest(self) -> bytes:
        raw = self.data[self.pos :]
        self.pos = len(self.data)
        return raw

    def byte(self, field: str) -> int:
        pos = self.pos
        if pos >= len(self.data):
            return self.take(1, field)[0]  # raises the take's FieldError
        self.pos = pos + 1
        return self.data[pos]

    def code(self, field: str, lo: int, hi: int, *, flag: int = FLAG_REJECTED) -> int:
        """A one-byte ASCII digit in ``lo..hi``."""
        raw = self.take(1, field)
        if not raw.isdigit():
            raise FieldError(self.command, field, f"{raw!r} is not a digit", flag=flag)
        return check_range(self.command, field, int(raw), lo, hi, flag=flag)

    def enum(self, field: str, kind: type[_E], *, flag: int = FLAG_REJECTED) -> _E:
        known = _ENUM_VALUES.get(kind)
        if known is None:
            values = [int(v) for v in kind]
            known = _ENUM_VALUES[kind] = (min(values), max(values), {int(v): v for v in kind})
        lo, hi, members = known
        value = self.code(field, lo, hi, flag=flag)
        member = members.get(value)
        if member is None:
            raise FieldError(self.command, field, f"{value} is not valid", flag=flag)
        return cast(_E, member)

    def channel(self, field: str = "channel") -> int:
        """The wire's ``'0'..'2'`` as pendant channel 1-3."""
        return self.code(field, 0, 2) + 1

    def number(
        self,
        n: int,
        field: str,
        *,
        lo: int | None = None,
        hi: int | None = None,
        flag: int = FLAG_REJECTED,
    ) -> int:
        value = parse_int(self.command, field, self.take(n, field), flag=flag)
        if lo is not None and hi is not None:
            check_range(self.command, field, value, lo, hi, flag=flag)
        return value

    def coord(self, field: str, width: int = COORD_WIDTH) -> float:
        return parse_coord(self.command, field, self.take(width, field))

    def text(self, n: int, field: str) -> str:
        return self.take(n, field).decode("ascii", "replace").strip()

    def name(self, n: int, field: str = "file name") -> FileName:
        return FileName.parse(self.take(n, field).decode("ascii", "replace"))

    def status(self, field: str) -> ChannelStatus:
        value = self.byte(field)
        if value & 0xC0 != 0x80:
            raise FieldError(self.command, field, f"status byte 0x{value:02X} lacks bit7=1 bit6=0")
        return ChannelStatus.from_byte(value)

    def end(self) -> None:
        """Fail if bytes are left over."""
        if len(self.data) > self.pos:
            raise FieldError(
                self.command, "packet", f"{self.remaining} unexpected bytes at the end"
            )
