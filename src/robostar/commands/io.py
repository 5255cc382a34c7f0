"""Group G, I/O: GA (read inputs), GB (read outputs), GC (set an output), GD (I/O boards).

Ports are 0-4 and contacts 0-15, both sent as two ASCII digits (``"01"``, ``"12"``). A port sent
as ``'0'`` and a raw byte, as one public client does, is answered 0x31.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Self

from robostar.commands.base import Command, NoData, NoParams, NumberField
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import Reader, decode_io_nibbles, encode_io_nibbles
from robostar.types import IOState

__all__ = ["ReadIOBoards", "ReadInputs", "ReadOutputs", "SetOutput"]

MAX_PORT = 4
CONTACTS = 16
MAX_BOARDS = 2


PORT = NumberField("port", 2, 0, MAX_PORT)
CONTACT = NumberField("contact", 2, 0, CONTACTS - 1)
INPUT_BOARDS = NumberField("input boards", 2, 0, MAX_BOARDS)
OUTPUT_BOARDS = NumberField("output boards", 2, 0, MAX_BOARDS)


@dataclass(frozen=True, slots=True)
class _ReadPort(Command[IOState]):
    """A read of one port's 16 contacts: the count ``"16"`` then four ``0x30 | nibble`` bytes."""

    port: int

    def encode_params(self) -> bytes:
        return PORT.encode(self.CODE, self.port)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        return cls(PORT.read(reader))

    def decode_answer(self, packets: Sequence[bytes]) -> IOState:
        r = self.single(packets)
        count = r.number(2, "contact count")
        if count != CONTACTS:
            raise MalformedAnswerError(self.CODE, f"{count} contacts where 16 were expected")
        contacts = decode_io_nibbles(self.CODE, r.take(4, "contact states"))
        r.end()
        return IOState(self.port, contacts)

    def encode_answer(self, result: IOState) -> list[bytes]:
        if result.port != self.port:
            raise FieldError(self.CODE, "port", f"state of port {result.port}, asked {self.port}")
        if len(result.contacts) != CONTACTS:
            raise FieldError(self.CODE, "contacts", f"need 16, got {len(result.contacts)}")
        return [self.ok(b"%02d" % CONTACTS + encode_io_nibbles(result.contacts))]


@dataclass(frozen=True, slots=True)
class ReadInputs(_ReadPort):
    """GA: read the 16 input contacts of a port (0-4)."""

    CODE = "GA"


@dataclass(frozen=True, slots=True)
class ReadOutputs(_ReadPort):
    """GB: read the 16 output contacts of a port (0-4)."""

    CODE = "GB"


@dataclass(frozen=True, slots=True)
class SetOutput(NoData):
    """GC: switch one output contact (0-15) of a port (0-4) on or off."""

    CODE = "GC"
    CHANGES_STATE = True
    port: int
    contact: int
    on: bool

    def encode_params(self) -> bytes:
        if not isinstance(self.on, bool):
            raise FieldError(self.CODE, "on", f"must be a bool, not {type(self.on).__name__}")
        return (
            PORT.encode(self.CODE, self.port)
            + CONTACT.encode(self.CODE, self.contact)
            + (b"1" if self.on else b"0")
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        port = PORT.read(reader)
        contact = CONTACT.read(reader)
        return cls(port, contact, bool(reader.code("on", 0, 1)))


@dataclass(frozen=True, slots=True)
class ReadIOBoards(NoParams, Command[tuple[int, int]]):
    """GD: how many input and output I/O boards the controller is set up with (0-2 each)."""

    CODE = "GD"

    def decode_answer(self, packets: Sequence[bytes]) -> tuple[int, int]:
        r = self.single(packets)
        inputs = INPUT_BOARDS.read(r)
        outputs = OUTPUT_BOARDS.read(r)
        r.end()
        return inputs, outputs

    def encode_answer(self, result: tuple[int, int]) -> list[bytes]:
        if len(result) != 2:
            raise FieldError(self.CODE, "boards", "give (input boards, output boards)")
        inputs, outputs = result
        body = INPUT_BOARDS.encode(self.CODE, inputs) + OUTPUT_BOARDS.encode(self.CODE, outputs)
        return [self.ok(body)]
