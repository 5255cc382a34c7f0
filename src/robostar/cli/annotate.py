"""Annotate captured line bytes frame by frame: direction, command, fields by name, flag, LRC.

Pure logic over :mod:`robostar.protocol.frame` and :mod:`robostar.commands`: bytes go in as
:class:`Chunk` s (with a direction when the capture knows it) and :class:`Annotated` frames come
out. Answers are decoded with the command of the request they answer, so a whole exchange reads
as the typed result the client would have returned.
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from robostar.cli.render import jsonable
from robostar.commands import COMMANDS, Command, decode_request, split_answer
from robostar.commands.base import Shape
from robostar.errors import RobostarError
from robostar.protocol.fields import (
    FLAG_END,
    FLAG_FAILED,
    FLAG_OK,
    FLAG_REJECTED,
    FLAG_UNSUPPORTED,
)
from robostar.protocol.frame import (
    ETX,
    Control,
    ControlKind,
    CorruptPacket,
    CorruptReason,
    FrameDecoder,
    Packet,
    lrc,
)

__all__ = [
    "FLAG_NAMES",
    "Annotated",
    "Annotator",
    "Chunk",
    "Direction",
    "annotate",
    "describe_request",
    "printable",
    "short",
]

FLAG_NAMES = {
    FLAG_OK: "OK",
    FLAG_REJECTED: "REJECTED",
    FLAG_FAILED: "FAILED",
    FLAG_UNSUPPORTED: "UNSUPPORTED",
    FLAG_END: "END",
}
_ERROR_FLAGS = (FLAG_REJECTED, FLAG_FAILED, FLAG_UNSUPPORTED)


class Direction(enum.Enum):
    TO_CONTROLLER = "host->ctrl"
    TO_HOST = "ctrl->host"

    @property
    def other(self) -> Direction:
        return Direction.TO_HOST if self is Direction.TO_CONTROLLER else Direction.TO_CONTROLLER


@dataclass(frozen=True, slots=True)
class Chunk:
    """Bytes seen on the line; ``direction`` is None when the capture does not say."""

    data: bytes
    direction: Direction | None = None
    time: float | None = None


@dataclass(frozen=True, slots=True)
class Annotated:
    """One frame (or lone control byte, or run of noise) and what it means."""

    index: int
    kind: str
    raw: bytes
    direction: Direction | None
    inferred: bool = False
    time: float | None = None
    command: str | None = None
    name: str | None = None
    flag: str | None = None
    lrc: str | None = None
    fields: dict[str, Any] = field(default_factory=dict)
    note: str = ""

    def as_json(self) -> dict[str, Any]:
        data = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        data["raw"] = self.raw.hex(" ")
        data["direction"] = self.direction.name.lower() if self.direction else None
        return data


def printable(data: bytes) -> str:
    """Bytes as text, with anything unprintable as an escape."""
    out = []
    for b in data:
        if 0x20 <= b < 0x7F and b != 0x5C:
            out.append(chr(b))
        elif b == 0x09:
            out.append("\\t")
        elif b == 0x0A:
            out.append("\\n")
        else:
            out.append(f"\\x{b:02x}")
    return "".join(out)


def _request_code(data: bytes) -> str | None:
    if len(data) >= 3 and data[0] == 0xFF:
        code = data[1:3].decode("ascii", "replace")
        if code in COMMANDS:
            return code
    return None


def _fields_of(command: Command[Any]) -> dict[str, Any]:
    return {f.name: jsonable(getattr(command, f.name)) for f in dataclasses.fields(command)}  # type: ignore[arg-type]


def describe_request(data: bytes) -> str:
    """A request packet's data as one line: ``AC ReadPosition channel=1 kind=xy``."""
    code = _request_code(data)
    if code is None:
        return f"not a request: {printable(data)}"
    try:
        command = decode_request(data)
    except RobostarError as error:
        return f"{code} (does not decode: {error})"
    fields = " ".join(f"{k}={short(v)}" for k, v in _fields_of(command).items())
    return f"{code} {type(command).__name__} {fields}".rstrip()


def short(value: Any) -> str:
    """A JSON-like value on one short line; a set of flags shows the ones that are on."""
    if isinstance(value, list):
        return "[" + ", ".join(short(v) for v in value) + "]"
    if isinstance(value, dict):
        if value and all(isinstance(v, bool) for v in value.values()):
            return "+".join(k for k, v in value.items() if v) or "-"
        return "{" + " ".join(f"{k}={short(v)}" for k, v in value.items()) + "}"
    return str(value)


@dataclass
class _Exchange:
    code: str
    command: Command[Any] | None
    shape: Shape
    packets: list[bytes] = field(default_factory=list)
    uploading: bool = False
    done: bool = False
    last_answer: bytes | None = None
    acked: bool = True


class Annotator:
    """Feed :class:`Chunk` s in line order; collects :attr:`frames`."""

    def __init__(self) -> None:
        self._decoders: dict[Direction | None, FrameDecoder] = {}
        self._exchange: _Exchange | None = None
        self._last_sender: Direction | None = None
        self.frames: list[Annotated] = []

    def feed(self, chunk: Chunk) -> list[Annotated]:
        decoder = self._decoders.setdefault(chunk.direction, FrameDecoder())
        before = len(self.frames)
        discarded = decoder.discarded
        for event in decoder.feed(chunk.data):
            if isinstance(event, Packet):
                self._packet(event.data, chunk)
            elif isinstance(event, Control):
                self._control(event.kind, chunk)
            else:
                self._corrupt(event, chunk)
        if decoder.discarded > discarded:
            count = decoder.discarded - discarded
            self._add(
                "noise",
                b"",
                chunk.direction,
                chunk,
                note=f"{count} byte(s) outside any frame, ignored",
            )
        return self.frames[before:]

    def finish(self) -> list[Annotated]:
        """Report a frame left unfinished at the end of the capture."""
        out = []
        for direction, decoder in self._decoders.items():
            if decoder.pending:
                out.append(
                    self._add(
                        "partial",
                        b"",
                        direction,
                        Chunk(b"", direction),
                        note=f"capture ends inside a frame ({decoder.pending} bytes)",
                    )
                )
        return out

    # -- events ----------------------------------------------------------------------------
    def _add(
        self,
        kind: str,
        raw: bytes,
        direction: Direction | None,
        chunk: Chunk,
        *,
        inferred: bool = False,
        **info: Any,
    ) -> Annotated:
        frame = Annotated(
            len(self.frames) + 1,
            kind,
            raw,
            direction,
            inferred,
            chunk.time,
            **info,
        )
        self.frames.append(frame)
        return frame

    def _sender(self, chunk: Chunk, guess: Direction) -> tuple[Direction, bool]:
        if chunk.direction is not None:
            return chunk.direction, False
        return guess, True

    def _packet(self, data: bytes, chunk: Chunk) -> None:
        raw = _framed(data)
        exchange = self._exchange
        code = _request_code(data)
        uploading = exchange is not None and exchange.uploading and not exchange.done
        if chunk.direction is Direction.TO_CONTROLLER or (chunk.direction is None and code):
            direction, inferred = self._sender(chunk, Direction.TO_CONTROLLER)
            if code:
                self._request(code, data, raw, chunk, direction, inferred)
            elif uploading and data[:1] in (b"\x30", b"\x34"):
                self._upload_packet(data, raw, chunk, direction, inferred)
            else:
                self._add(
                    "packet",
                    raw,
                    direction,
                    chunk,
                    inferred=inferred,
                    lrc="ok",
                    note=f"not a request: {printable(data)}",
                )
        elif chunk.direction is None and uploading and data[:1] in (b"\x30", b"\x34"):
            self._upload_packet(data, raw, chunk, Direction.TO_CONTROLLER, True)
        else:
            direction, inferred = self._sender(chunk, Direction.TO_HOST)
            self._answer(data, raw, chunk, direction, inferred)
        self._last_sender = self.frames[-1].direction

    def _request(
        self,
        code: str,
        data: bytes,
        raw: bytes,
        chunk: Chunk,
        direction: Direction,
        inferred: bool,
    ) -> None:
        command: Command[Any] | None = None
        note = ""
        info: dict[str, Any] = {}
        try:
            command = decode_request(data)
            info = _fields_of(command)
        except RobostarError as error:
            note = f"does not decode: {error}"
        previous = self._exchange
        if previous is not None and not previous.packets and previous.code == code:
            note = (note + "; " if note else "") + "sent again"
        shape = type(command).SHAPE if command else COMMANDS[code][0].SHAPE
        self._exchange = _Exchange(code, command, shape)
        self._add(
            "request",
            raw,
            direction,
            chunk,
            inferred=inferred,
            command=code,
            name=type(command).__name__ if command else None,
            lrc="ok",
            fields=info,
            note=note,
        )

    def _upload_packet(
        self, data: bytes, raw: bytes, chunk: Chunk, direction: Direction, inferred: bool
    ) -> None:
        end = data[:1] == b"\x34"
        self._add(
            "upload end" if end else "upload line",
            raw,
            direction,
            chunk,
            inferred=inferred,
            command="FB",
            lrc="ok",
            fields={} if end else {"line": data[1:].decode("ascii", "replace")},
        )

    def _answer(
        self, data: bytes, raw: bytes, chunk: Chunk, direction: Direction, inferred: bool
    ) -> None:
        answer = split_answer(data)
        flag = FLAG_NAMES.get(answer.flag, f"0x{answer.flag:02X}?")
        exchange = self._exchange
        info: dict[str, Any] = {}
        note = ""
        if exchange is None or (exchange.done and not exchange.uploading):
            if exchange is not None and exchange.last_answer == data and not exchange.acked:
                note = "sent again (no ACK came)"
            else:
                note = "an answer with no request before it in the capture"
            if answer.body:
                info["body"] = printable(answer.body)
            self._add(
                "answer",
                raw,
                direction,
                chunk,
                inferred=inferred,
                command=exchange.code if exchange else None,
                flag=flag,
                lrc="ok",
                fields=info,
                note=note,
            )
            return
        if exchange.last_answer == data and not exchange.acked:
            note = "sent again (no ACK came)"
        else:
            note = self._advance(exchange, data, answer.flag, answer.body, info)
        exchange.last_answer = data
        exchange.acked = False
        self._add(
            "answer",
            raw,
            direction,
            chunk,
            inferred=inferred,
            command=exchange.code,
            name=type(exchange.command).__name__ if exchange.command else None,
            flag=flag,
            lrc="ok",
            fields=info,
            note=note,
        )

    def _advance(
        self, exchange: _Exchange, data: bytes, flag: int, body: bytes, info: dict[str, Any]
    ) -> str:
        """Take one new answer packet into the exchange; fill ``info``; return a note."""
        if flag in _ERROR_FLAGS:
            exchange.done = True
            exchange.uploading = False
            return {
                FLAG_REJECTED: "the controller did not understand the request",
                FLAG_FAILED: "the function failed; KD tells why",
                FLAG_UNSUPPORTED: "not supported by this controller",
            }[flag]
        if exchange.shape is Shape.UPLOAD:
            if not exchange.uploading and not exchange.packets:
                exchange.uploading = True
                exchange.packets.append(data)
                return "ready for the file's lines"
            exchange.packets.append(data)
            return "line taken"
        exchange.packets.append(data)
        if body:
            info["body"] = printable(body)
        complete = (
            exchange.shape is Shape.SINGLE
            or (exchange.shape is Shape.MULTI and flag == FLAG_END)
            or (exchange.shape is Shape.TWO_PHASE and len(exchange.packets) == 2)
        )
        if exchange.shape is Shape.TWO_PHASE and len(exchange.packets) == 1:
            text = body.decode("ascii", "replace").strip()
            if text.isdigit():
                info["wait_s"] = int(text)
            return "first answer; the second comes when the action is done"
        if not complete:
            return f"part {len(exchange.packets)}"
        exchange.done = True
        if exchange.command is None:
            return ""
        try:
            result = exchange.command.decode_answer(exchange.packets)
        except RobostarError as error:
            return f"answer does not decode: {error}"
        except (ValueError, IndexError) as error:
            return f"answer does not decode: {error}"
        info["result"] = jsonable(result)
        return ""

    def _control(self, kind: ControlKind, chunk: Chunk) -> None:
        guess = self._last_sender.other if self._last_sender else Direction.TO_HOST
        direction, inferred = self._sender(chunk, guess)
        exchange = self._exchange
        note = ""
        if kind is ControlKind.ACK:
            if exchange is not None:
                exchange.acked = True
                if exchange.uploading and direction is Direction.TO_HOST:
                    exchange.uploading = False
                    exchange.done = True
                    note = "upload accepted"
        elif kind is ControlKind.NAK:
            note = "the last packet arrived damaged: send it again"
        else:
            note = "exchange aborted"
            self._exchange = None
        self._add(
            kind.name.lower(),
            bytes((kind.value,)),
            direction,
            chunk,
            inferred=inferred,
            command=exchange.code if exchange else None,
            note=note,
        )
        self._last_sender = direction

    def _corrupt(self, event: CorruptPacket, chunk: Chunk) -> None:
        raw = event.raw
        if event.reason is CorruptReason.BAD_LRC:
            data = raw[1:-2]
            want = lrc(data) or ETX
            verdict = f"bad: got 0x{raw[-1]:02X}, want 0x{want:02X}"
        else:
            data = raw[1:]
            verdict = event.reason.value
        code = _request_code(data)
        self._add(
            "corrupt",
            raw,
            chunk.direction,
            chunk,
            command=code,
            lrc=verdict,
            fields={"data": printable(data)},
            note="the receiver answers NAK",
        )
        if chunk.direction is not None:
            self._last_sender = chunk.direction


def _framed(data: bytes) -> bytes:
    check = lrc(data)
    return bytes((0x02, *data, ETX, check if check else ETX))


def annotate(chunks: Iterable[Chunk]) -> list[Annotated]:
    """Every frame of a capture, annotated."""
    annotator = Annotator()
    for chunk in chunks:
        annotator.feed(chunk)
    annotator.finish()
    return annotator.frames
