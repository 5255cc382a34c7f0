"""Wire trace: every frame sent and received, with what it means, as JSON lines.

``trace=`` on a client takes a path (JSON lines appended to it) or a callable (given each
:class:`TraceRecord`). Bytes are framed again here, per direction, so a record is one whole
packet or one control byte however the transport split the bytes.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import IO, Any

from robostar.commands.base import split_answer
from robostar.commands.registry import decode_request
from robostar.errors import RobostarError, UsageError
from robostar.protocol.fields import FLAG_END, FLAG_OK, FileName
from robostar.protocol.frame import Control, CorruptPacket, FrameDecoder, Packet, encode_packet

__all__ = ["TraceRecord", "TraceTarget", "WireTrace"]

TX = "tx"
RX = "rx"


@dataclass(frozen=True, slots=True)
class TraceRecord:
    """One frame on the wire.

    ``time`` is wall-clock seconds (``time.time()``); ``direction`` is ``"tx"`` (host to
    controller) or ``"rx"``; ``kind`` is ``"request"``, ``"answer"``, ``"upload line"``,
    ``"upload end"``, ``"ACK"``, ``"NAK"``, ``"RST"`` or ``"corrupt"``. ``command`` is the two
    letters of the request (for answers: of the exchange in progress), ``flag`` the answer flag
    (``"0x30"``), ``fields`` the request's fields or the answer's text.
    """

    time: float
    direction: str
    hex: str
    kind: str
    command: str | None = None
    flag: str | None = None
    fields: dict[str, Any] | None = None

    def as_dict(self) -> dict[str, Any]:
        return {k: v for k, v in dataclasses.asdict(self).items() if v is not None}

    def to_json(self) -> str:
        return json.dumps(self.as_dict(), separators=(",", ":"))


TraceTarget = str | os.PathLike[str] | Callable[[TraceRecord], object]


def _plain(value: object) -> object:
    """A field value as JSON-ready data."""
    if isinstance(value, enum.Enum):
        return value.name
    if isinstance(value, FileName):
        return str(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    return value


def _request_meaning(data: bytes) -> tuple[str | None, dict[str, Any] | None]:
    code = data[1:3].decode("ascii", "replace")
    try:
        command = decode_request(data)
    except RobostarError:
        return code, None
    fields = _plain(command)
    return command.CODE, fields if isinstance(fields, dict) else None


class WireTrace:
    """Turns the bytes a client writes and reads into :class:`TraceRecord` s for a target."""

    def __init__(self, target: TraceTarget, *, clock: Callable[[], float] = time.time) -> None:
        self._clock = clock
        self._file: IO[str] | None = None
        if callable(target):
            self._emit: Callable[[TraceRecord], object] = target
        elif isinstance(target, str | os.PathLike):
            try:
                self._file = open(target, "a", encoding="utf-8", buffering=1)  # noqa: SIM115
            except OSError as exc:
                raise UsageError(f"trace: cannot open {os.fspath(target)!r}: {exc}") from exc
            file = self._file
            self._emit = lambda record: file.write(record.to_json() + "\n")
        else:
            raise UsageError(f"trace must be a path or a callable, not {type(target).__name__}")
        self._decoders = {TX: FrameDecoder(), RX: FrameDecoder()}
        self.command: str | None = None
        """The command of the exchange in progress, to label answers."""

    def sent(self, data: bytes) -> None:
        self._feed(TX, data)

    def received(self, data: bytes) -> None:
        self._feed(RX, data)

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def _feed(self, direction: str, data: bytes) -> None:
        now = self._clock()
        for event in self._decoders[direction].feed(data):
            if isinstance(event, Control):
                record = TraceRecord(now, direction, f"{event.kind.value:02x}", event.kind.name)
            elif isinstance(event, CorruptPacket):
                record = TraceRecord(
                    now,
                    direction,
                    event.raw.hex(" "),
                    "corrupt",
                    self.command,
                    fields={"reason": event.reason.value},
                )
            else:
                record = self._packet(now, direction, event)
            self._emit(record)

    def _packet(self, now: float, direction: str, packet: Packet) -> TraceRecord:
        data = packet.data
        wire = encode_packet(data).hex(" ")
        if direction == TX and data[:1] == b"\xff":
            code, fields = _request_meaning(data)
            self.command = code
            return TraceRecord(now, direction, wire, "request", code, fields=fields)
        if direction == TX:
            kind = "upload end" if data[:1] == bytes((FLAG_END,)) else "upload line"
            text = data[1:].decode("ascii", "replace")
            fields = {"line": text.removesuffix("\n")} if data[:1] == bytes((FLAG_OK,)) else None
            return TraceRecord(now, direction, wire, kind, self.command, fields=fields)
        try:
            answer = split_answer(data)
        except RobostarError:
            return TraceRecord(now, direction, wire, "answer", self.command)
        body = answer.body
        # Text answers are shown as text; binary ones (AA's status bytes) are in ``hex`` only.
        readable = body and all(0x20 <= b < 0x7F or b in (0x09, 0x0A) for b in body)
        fields = {"body": body.decode("ascii")} if readable else None
        flag = f"0x{answer.flag:02x}"
        return TraceRecord(now, direction, wire, "answer", self.command, flag, fields)
