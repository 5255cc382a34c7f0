"""The shape shared by every command: a typed request that knows its answer, in both directions.

A command class is the request. It encodes itself (host side) and decodes itself from a packet
(controller side, so the simulator needs no second codec). It also decodes the answer packets of
its exchange into a typed result (host side) and encodes a result into answer packets
(controller side). Answer packets are handed over whole, as the link delivered them, flag first
(after the optional dummy byte); error flags never reach ``decode_answer``.

Besides :class:`Command`, the building blocks the groups share: request mixins (:class:`NoParams`,
:class:`ChannelOnly`), answer bases (:class:`NoData`, :class:`NumberAnswer`), the
:class:`NumberField` codec and helpers for file names and axis values.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Generic, Self, TypeVar

from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import (
    COORD_WIDTH,
    FLAG_END,
    FLAG_OK,
    FLAG_REJECTED,
    FileName,
    Reader,
    encode_channel,
    encode_coord,
    encode_int,
)
from robostar.protocol.packets import AnswerPacket, Shape, make_answer, split_answer

__all__ = [
    "FILE_NAME_WIDTH",
    "AnswerPacket",
    "ChannelOnly",
    "Command",
    "NoData",
    "NoParams",
    "NumberAnswer",
    "NumberField",
    "Shape",
    "encode_axes",
    "encode_file_of_kind",
    "file_arg",
    "make_answer",
    "read_axes",
    "read_file_of_kind",
    "set_fields",
    "split_answer",
]

T = TypeVar("T")

FILE_NAME_WIDTH = 12
"""A file name field: 12 bytes, as :meth:`FileName.encode` writes it."""


class Command(ABC, Generic[T]):
    """A request of the host protocol; ``T`` is the type of its decoded answer.

    Subclasses are frozen dataclasses that set:

    - ``CODE``: the two letters, e.g. ``"AA"``;
    - ``SHAPE``: how the exchange runs;
    - ``CHANGES_STATE``: True when the command changes the controller (motion, writes, file
      changes, job control), so that it is never resent after a lost answer;
    - ``ANSWER_DUMMY``: True when the manual's answer starts with ``FF`` before the flag;
    - ``MAX_PACKETS`` (multi-packet answers): how many packets the answer can hold at most;

    and implement ``encode_params``/``decode_params`` (the request after ``FF G1 G2``) and
    ``decode_answer``/``encode_answer`` (the answer packets, host and controller side), or
    take them from the mixins and bases below.
    """

    CODE: ClassVar[str]
    SHAPE: ClassVar[Shape] = Shape.SINGLE
    CHANGES_STATE: ClassVar[bool] = False
    ANSWER_DUMMY: ClassVar[bool] = False
    MAX_PACKETS: ClassVar[int | None] = None
    """Multi-packet answers: the most packets (END included) the answer can hold; None: the
    link's general cap."""
    DISTINCT_PACKETS: ClassVar[bool] = False
    """Multi-packet answers: no two packets of an answer are equal (each names its file or
    record), so a copy of the packet just ACKed is always the controller resending it."""
    _HEAD: ClassVar[bytes] = b""
    """``FF G1 G2``, made once per class (every request starts with it)."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        code = getattr(cls, "CODE", None)  # its own or inherited
        if isinstance(code, str):
            cls._HEAD = b"\xff" + code.encode("ascii")

    # -- request ---------------------------------------------------------------------------
    @abstractmethod
    def encode_params(self) -> bytes:
        """The request's fields after ``FF G1 G2``; checks every limit first."""

    @classmethod
    @abstractmethod
    def decode_params(cls, reader: Reader) -> Self:
        """Read the request's fields (controller side); raise FieldError on a bad field."""

    @classmethod
    def matches(cls, params: bytes) -> bool:
        """For codes with variants (GR, GW): does this class handle these params?"""
        return True

    def encode(self) -> bytes:
        """The request packet's data: ``FF G1 G2 params``."""
        return self._HEAD + self.encode_params()

    @classmethod
    def decode(cls, data: bytes) -> Self:
        """Decode a request packet's data (``FF G1 G2 params``), controller side."""
        if data[:1] != b"\xff" or data[1:3] != cls.CODE.encode("ascii"):
            raise FieldError(cls.CODE, "header", f"{data[:3]!r} is not FF {cls.CODE}")
        reader = Reader(cls.CODE, data, 3)
        request = cls.decode_params(reader)
        reader.end()
        return request

    # -- answer ----------------------------------------------------------------------------
    @abstractmethod
    def decode_answer(self, packets: Sequence[bytes]) -> T:
        """Decode the exchange's answer packets (all of them, END included) into the result."""

    @abstractmethod
    def encode_answer(self, result: T) -> list[bytes]:
        """Encode a result as the exchange's answer packets (controller side)."""

    # -- helpers for subclasses -----------------------------------------------------------
    def ok(self, body: bytes = b"") -> bytes:
        """An OK answer packet with this command's dummy convention."""
        return make_answer(FLAG_OK, body, dummy=self.ANSWER_DUMMY)

    def end(self) -> bytes:
        """The END (0x34) packet closing a multi-packet answer."""
        return make_answer(FLAG_END, dummy=self.ANSWER_DUMMY)

    def error_answer(self, flag: int) -> bytes:
        """An error answer packet (0x31/0x32/0x33) for this command."""
        return make_answer(flag, dummy=self.ANSWER_DUMMY)

    def reader(self, packet: bytes, *, flag: int = FLAG_OK) -> Reader:
        """A Reader over one answer packet's body, checking its flag."""
        answer = split_answer(packet)
        if answer.flag != flag:
            raise MalformedAnswerError(
                self.CODE, f"flag 0x{answer.flag:02X} where 0x{flag:02X} was expected", packet
            )
        return Reader(self.CODE, answer.body)

    def expect_packets(self, packets: Sequence[bytes], count: int) -> None:
        """Fail unless the answer is exactly ``count`` packets."""
        if len(packets) != count:
            were = "was" if count == 1 else "were"
            raise MalformedAnswerError(
                self.CODE, f"{len(packets)} packets where {count} {were} expected"
            )

    def single(self, packets: Sequence[bytes]) -> Reader:
        """The Reader over a SINGLE exchange's only packet."""
        if len(packets) != 1:
            self.expect_packets(packets, 1)  # raises
        return self.reader(packets[0])

    def bare_flags(self, packets: Sequence[bytes]) -> None:
        """Fail unless every packet is a bare OK flag."""
        for packet in packets:
            self.reader(packet).end()

    def multi_bodies(self, packets: Sequence[bytes]) -> list[bytes]:
        """The bodies of a MULTI exchange's 0x30 packets, checking the closing 0x34."""
        if not packets or split_answer(packets[-1]).flag != FLAG_END:
            raise MalformedAnswerError(self.CODE, "multi-packet answer not closed by 0x34")
        bodies = []
        for packet in packets[:-1]:
            answer = split_answer(packet)
            if answer.flag != FLAG_OK:
                raise MalformedAnswerError(
                    self.CODE, f"flag 0x{answer.flag:02X} inside a multi-packet answer", packet
                )
            bodies.append(answer.body)
        return bodies


class NoData(Command[None]):
    """Base for commands whose answer is a bare flag (one per phase, when two-phase)."""

    def _phases(self) -> int:
        return 2 if self.SHAPE is Shape.TWO_PHASE else 1

    def decode_answer(self, packets: Sequence[bytes]) -> None:
        self.expect_packets(packets, self._phases())
        self.bare_flags(packets)

    def encode_answer(self, result: None) -> list[bytes]:
        return [self.ok()] * self._phases()


@dataclass(frozen=True, slots=True)
class NumberField:
    """A right-aligned number of ``width`` bytes in ``lo..hi``, written and read alike."""

    name: str
    width: int
    lo: int
    hi: int
    pad: str = "0"

    def encode(self, command: str, value: int) -> bytes:
        return encode_int(
            command, self.name, value, self.width, lo=self.lo, hi=self.hi, pad=self.pad
        )

    def read(self, reader: Reader) -> int:
        return reader.number(self.width, self.name, lo=self.lo, hi=self.hi)


class NumberAnswer(Command[int]):
    """Base for commands whose answer is one number, the ``ANSWER`` field."""

    ANSWER: ClassVar[NumberField]

    def decode_answer(self, packets: Sequence[bytes]) -> int:
        r = self.single(packets)
        value = self.ANSWER.read(r)
        r.end()
        return value

    def encode_answer(self, result: int) -> list[bytes]:
        return [self.ok(self.ANSWER.encode(self.CODE, result))]


# Request mixins: put them before the Command base, so their methods are the ones used.
class NoParams:
    """Mixin for a request with no fields after ``FF G1 G2``."""

    __slots__ = ()
    _HEAD: bytes  # Command's

    def encode(self) -> bytes:
        """The request packet's data: ``FF G1 G2`` and nothing after it."""
        return self._HEAD

    def encode_params(self) -> bytes:
        return b""

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        return cls()


class ChannelOnly:
    """Mixin for a request whose only field is ``channel`` (1-3, sent as ``'0'..'2'``)."""

    __slots__ = ()
    CODE: ClassVar[str]
    channel: int

    if TYPE_CHECKING:
        # The dataclass mixing this in declares ``channel`` and generates the real __init__.
        def __init__(self, channel: int) -> None: ...

    def encode_params(self) -> bytes:
        return encode_channel(self.CODE, self.channel)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        return cls(reader.channel())


# -- field helpers shared by several groups --------------------------------------------------
def set_fields(obj: object, **values: object) -> None:
    """Set a frozen request's fields (its ``__init__`` converts the arguments first)."""
    for field, value in values.items():
        object.__setattr__(obj, field, value)


def file_arg(value: FileName | str) -> FileName:
    """A file argument kept as a FileName, so that a request equals its decoded copy."""
    return FileName.exact(value) if isinstance(value, str) else value


def encode_file_of_kind(command: str, file: FileName, kind: str) -> bytes:
    """BB's and DC's ``file``: a .JOB or .PNT (``kind``) name in 12 bytes, right-aligned.

    A wrong case or kind is answered 0x31 by these two commands (0x32 elsewhere).
    """
    if not isinstance(file, FileName):
        raise FieldError(command, "file", "must be a FileName or a str")
    name = file.check(command, "file", kind=kind, case_flag=FLAG_REJECTED)
    return name.encode(command, "file", FILE_NAME_WIDTH)


def read_file_of_kind(reader: Reader, kind: str) -> FileName:
    """Read the name :func:`encode_file_of_kind` writes, checked the same way."""
    name = reader.name(FILE_NAME_WIDTH, "file")
    return name.check(reader.command, "file", kind=kind, case_flag=FLAG_REJECTED)


def _axis_field(field: str, axis: int) -> str:
    return f"{field} axis {axis}" if field else f"axis {axis}"


def encode_axes(
    command: str,
    values: Iterable[float],
    field: str = "",
    width: int = COORD_WIDTH,
    *,
    exact: bool = False,
) -> bytes:
    """Axis values side by side, ``width`` bytes each with 3 decimals (``"{field} axis N"``);
    ``exact``: refuse a value finer than 0.001 (a request) instead of rounding it."""
    return b"".join(
        encode_coord(command, _axis_field(field, axis), value, width, exact=exact)
        for axis, value in enumerate(values, 1)
    )


def read_axes(
    reader: Reader, count: int, field: str = "", width: int = COORD_WIDTH
) -> tuple[float, ...]:
    """Read ``count`` axis values written by :func:`encode_axes`."""
    names = _AXIS_NAMES if not field and count <= len(_AXIS_NAMES) else None
    if names is None:
        names = tuple(_axis_field(field, axis) for axis in range(1, count + 1))
    coord = reader.coord
    return tuple([coord(names[i], width) for i in range(count)])


_AXIS_NAMES = tuple(_axis_field("", axis) for axis in range(1, 7))
"""The field names of up to six plain axis values, made once."""
