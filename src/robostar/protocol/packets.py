"""Answer-packet layout and exchange shapes, shared by the link machine and the commands."""

from __future__ import annotations

import enum

from robostar.errors import MalformedAnswerError
from robostar.protocol.frame import DUMMY

__all__ = ["AnswerPacket", "Shape", "make_answer", "split_answer"]


class Shape(enum.Enum):
    """How an exchange runs on the link (see docs/protocol.md, "Exchange shapes")."""

    SINGLE = "single"
    """One answer packet, ACKed."""
    MULTI = "multi"
    """Answer packets with flag 0x30, each ACKed, closed by a packet with flag 0x34."""
    TWO_PHASE = "two-phase"
    """A first answer (DB/DC carry the expected wait), ACKed; a second when done, ACKed."""
    UPLOAD = "upload"
    """FB: the host sends the packets, the controller answers each, a lone ACK closes."""


class AnswerPacket:
    """One answer packet split into its flag and body."""

    __slots__ = ("body", "dummy", "flag")

    def __init__(self, flag: int, body: bytes, dummy: bool):
        self.flag = flag
        self.body = body
        self.dummy = dummy

    def __repr__(self) -> str:
        return f"AnswerPacket(flag=0x{self.flag:02X}, body={self.body!r}, dummy={self.dummy})"


def split_answer(data: bytes) -> AnswerPacket:
    """Split an answer packet's data into dummy, flag and body (a leading FF is optional)."""
    dummy = bool(data) and data[0] == DUMMY
    offset = 1 if dummy else 0
    if len(data) <= offset:
        raise MalformedAnswerError("", "empty answer packet", data)
    return AnswerPacket(data[offset], data[offset + 1 :], dummy)


def make_answer(flag: int, body: bytes = b"", *, dummy: bool = False) -> bytes:
    """Build an answer packet's data: ``[FF] FLAG body``."""
    return (b"\xff" if dummy else b"") + bytes((flag,)) + body
