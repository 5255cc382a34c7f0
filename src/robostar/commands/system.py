"""Group K, system: KD (the reason for the last 0x32) and KE (parameter data)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Self

from robostar.commands.base import Command, NoParams, Shape
from robostar.errors import FieldError
from robostar.protocol.fields import Reader, check_range, encode_channel, encode_int, encode_text
from robostar.protocol.frame import MAX_PACKET

__all__ = ["ReadLastError", "ReadParameters"]

MAX_TEXT = MAX_PACKET - 5
"""Text bytes that fit one answer packet: 250 less STX, ETX, LRC, the dummy and the flag."""
PUBLIC = 4
"""KE's channel code for the public parameters (PUB_PARA)."""
ALL = -1
"""KE's index for "all data"."""
MAX_INDEX = 99
"""KE's index is two digits: groups 1-99 (the manual's tables use 1-98)."""
KE_PACKETS_PER_INDEX = 10
"""The most packets one KE group may take. The manual leaves each packet's layout open ("the
data's length depends on what is asked"); its largest groups hold a value per axis (6 axes),
so ten packets of up to 245 bytes (2,450 bytes a group) is well over any of them."""


def _text(command: str, field: str, text: str) -> bytes:
    """ASCII text of any length up to :data:`MAX_TEXT`, as one packet's body."""
    if not isinstance(text, str):
        raise FieldError(command, field, f"must be a str, not {type(text).__name__}")
    if len(text) > MAX_TEXT:
        raise FieldError(command, field, f"{len(text)} characters is over {MAX_TEXT}")
    return encode_text(command, field, text, len(text))


@dataclass(frozen=True, slots=True)
class ReadLastError(NoParams, Command[str]):
    """KD: the text of the last communication error (why a command got 0x32), shared by all
    channels, e.g. ``"LRC is different with received data LRC"``."""

    CODE = "KD"
    ANSWER_DUMMY = True

    def decode_answer(self, packets: Sequence[bytes]) -> str:
        return self.single(packets).rest().decode("ascii", "replace").strip()

    def encode_answer(self, result: str) -> list[bytes]:
        return [self.ok(_text(self.CODE, "text", result))]


def _check_index(command: str, index: int) -> int:
    check_range(command, "index", index, ALL, MAX_INDEX)
    if index == 0:
        raise FieldError(command, "index", "0 is not an index: use -1 (all) or 1-99")
    return index


@dataclass(frozen=True, slots=True)
class ReadParameters(Command[tuple[str, ...]]):
    """KE: read parameter data of a channel (1-3) or, with ``channel`` None, the public
    parameters; ``index`` -1 asks for all of it, 1-99 for one group (the manual's table).

    The wire's channel byte is '0'-'2' for channels 1-3 and '4' for the public parameters; the
    index is 2 bytes (``" 4"``, ``"-1"``). Each answer packet holds one piece of data, whose
    length depends on what was asked; they come back as strings, in order.
    """

    CODE = "KE"
    SHAPE = Shape.MULTI
    ANSWER_DUMMY = True
    MAX_PACKETS = MAX_INDEX * KE_PACKETS_PER_INDEX + 1
    """``-1`` asks for every group (indexes 1-99), each of up to ten packets, then END (991)."""
    channel: int | None
    index: int = ALL

    def encode_params(self) -> bytes:
        channel = (
            b"%d" % PUBLIC if self.channel is None else encode_channel(self.CODE, self.channel)
        )
        index = _check_index(self.CODE, self.index)
        return channel + encode_int(self.CODE, "index", index, 2, pad=" ")

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        code = reader.code("channel", 0, PUBLIC)
        if code == 3:
            raise FieldError(cls.CODE, "channel", "'3' is neither a channel nor '4' (public)")
        index = _check_index(cls.CODE, reader.number(2, "index"))
        return cls(None if code == PUBLIC else code + 1, index)

    def decode_answer(self, packets: Sequence[bytes]) -> tuple[str, ...]:
        return tuple(body.decode("ascii", "replace") for body in self.multi_bodies(packets))

    def encode_answer(self, result: tuple[str, ...]) -> list[bytes]:
        packets = [self.ok(_text(self.CODE, f"data {i}", text)) for i, text in enumerate(result, 1)]
        return [*packets, self.end()]
