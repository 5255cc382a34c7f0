"""The shape shared by every command: a typed request that knows its answer, in both directions.

A command class is the request. It encodes itself (host side) and decodes itself from a packet
(controller side, so the simulator needs no second codec). It also decodes the answer packets of
its exchange into a typed result (host side) and encodes a result into answer packets
(controller side). Answer packets are handed over whole, as the link delivered them, flag first
(after the optional dummy byte); error flags never reach ``decode_answer``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import ClassVar, Generic, Self, TypeVar

from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import FLAG_END, FLAG_OK, Reader
from robostar.protocol.packets import AnswerPacket, Shape, make_answer, split_answer

__all__ = [
    "AnswerPacket",
    "Command",
    "NoData",
    "Shape",
    "make_answer",
    "split_answer",
]

T = TypeVar("T")


class Command(ABC, Generic[T]):
    """A request of the host protocol; ``T`` is the type of its decoded answer.

    Subclasses are frozen dataclasses that set:

    - ``CODE``: the two letters, e.g. ``"AA"``;
    - ``SHAPE``: how the exchange runs;
    - ``CHANGES_STATE``: True when the command changes the controller (motion, writes, file
      changes, job control), so that it is never resent after a lost answer;
    - ``ANSWER_DUMMY``: True when the manual's answer starts with ``FF`` before the flag;

    and implement ``encode_params``/``decode_params`` (the request after ``FF G1 G2``) and
    ``decode_answer``/``encode_answer`` (the answer packets, host and controller side).
    """

    CODE: ClassVar[str]
    SHAPE: ClassVar[Shape] = Shape.SINGLE
    CHANGES_STATE: ClassVar[bool] = False
    ANSWER_DUMMY: ClassVar[bool] = False

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
        return b"\xff" + self.CODE.encode("ascii") + self.encode_params()

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

    def single(self, packets: Sequence[bytes]) -> Reader:
        """The Reader over a SINGLE exchange's only packet."""
        if len(packets) != 1:
            raise MalformedAnswerError(self.CODE, f"{len(packets)} packets where 1 was expected")
        return self.reader(packets[0])

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
    """Base for commands whose answer is a bare flag."""

    def decode_answer(self, packets: Sequence[bytes]) -> None:
        self.single(packets).end()

    def encode_answer(self, result: None) -> list[bytes]:
        return [self.ok()]
