"""Read a capture into chunks of line bytes: a hex dump, a raw byte capture, or a trace file.

- Hex dump: whitespace-separated hex bytes (``02 FF 41 41 03 BC``, ``0x02``, ``02FF4141``), one
  exchange or many per line. A line may start with a direction: ``>`` / ``TX`` / ``host`` for
  host to controller, ``<`` / ``RX`` / ``ctrl`` for controller to host. ``xxd`` and
  ``hexdump -C`` output are read too (offsets and the ASCII column are skipped). ``#`` starts a
  comment.
- Raw: the bytes as they came off the line, one direction or both interleaved.
- Trace: the client's ``--trace`` file, one JSON object per line with a direction, the bytes in
  hex, and a time.
"""

from __future__ import annotations

import enum
import json
import re
from collections.abc import Mapping
from typing import Any

from robostar.cli.annotate import Chunk, Direction
from robostar.errors import UsageError

__all__ = ["CaptureFormat", "detect_format", "parse_capture", "parse_hexdump", "parse_trace"]


class CaptureFormat(enum.Enum):
    AUTO = "auto"
    HEX = "hex"
    RAW = "raw"
    TRACE = "trace"


_TO_CONTROLLER = {
    ">", "->", "tx", "out", "send", "sent", "host", "h", "write", "to_controller",
    "host->ctrl", "h>", "request",
}  # fmt: skip
_TO_HOST = {
    "<", "<-", "rx", "in", "recv", "received", "ctrl", "controller", "c", "read", "to_host",
    "ctrl->host", "c>", "answer",
}  # fmt: skip

_DIRECTION_PREFIX = re.compile(
    r"^\s*(?P<dir>->|<-|>|<|[A-Za-z_>-]+)\s*:?\s+(?=\S)",
)
_HEX_TOKEN = re.compile(r"(?:0x)?([0-9A-Fa-f]{2})+")
_XXD_LINE = re.compile(r"^\s*[0-9A-Fa-f]{4,16}:\s")
_HEXDUMP_C = re.compile(
    r"^\s*([0-9A-Fa-f]{7,16})\s{1,2}((?:[0-9A-Fa-f]{2}\s{1,2}){1,16})\s*\|.*\|\s*$"
)


def parse_direction(word: str) -> Direction | None:
    """A direction word as traces and dumps spell it, or None."""
    low = word.strip().lower().rstrip(":")
    if low in _TO_CONTROLLER:
        return Direction.TO_CONTROLLER
    if low in _TO_HOST:
        return Direction.TO_HOST
    return None


def detect_format(data: bytes) -> CaptureFormat:
    """Guess a capture's format from its bytes."""
    head = data.lstrip()[:1]
    if head == b"{":
        return CaptureFormat.TRACE
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError:
        return CaptureFormat.RAW
    if any(c in text for c in "\x02\x03\x06\x15\x12"):
        return CaptureFormat.RAW
    return CaptureFormat.HEX


def parse_capture(data: bytes, fmt: CaptureFormat = CaptureFormat.AUTO) -> list[Chunk]:
    """The capture's chunks in line order."""
    if fmt is CaptureFormat.AUTO:
        fmt = detect_format(data)
    if fmt is CaptureFormat.RAW:
        return [Chunk(data)] if data else []
    text = data.decode("utf-8", "replace")
    if fmt is CaptureFormat.TRACE:
        return parse_trace(text)
    return parse_hexdump(text)


def _hex_bytes(tokens: list[str], lineno: int) -> bytes:
    out = bytearray()
    for token in tokens:
        cleaned = token.strip(",;")
        if not cleaned:
            continue
        if not _HEX_TOKEN.fullmatch(cleaned):
            raise UsageError(f"line {lineno}: {token!r} is not a hex byte (like 02 or 0x02)")
        out += bytes.fromhex(cleaned.removeprefix("0x").removeprefix("0X"))
    return bytes(out)


def parse_hexdump(text: str) -> list[Chunk]:
    """Chunks from a hex dump, one per line (see the module docstring for what it reads)."""
    chunks: list[Chunk] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].rstrip()
        if not line.strip():
            continue
        direction = None
        match = _DIRECTION_PREFIX.match(line)
        if match:
            found = parse_direction(match.group("dir"))
            if found is not None:
                direction = found
                line = line[match.end() :]
        dump_c = _HEXDUMP_C.match(line)
        if dump_c:
            tokens = dump_c.group(2).split()
        elif _XXD_LINE.match(line):
            # xxd: "offset: hex groups  ascii" - the ASCII column follows two spaces.
            hex_part = line.split(":", 1)[1].strip().split("  ", 1)[0]
            tokens = hex_part.split()
        else:
            tokens = line.replace(":", " ").replace("-", " ").split()
        data = _hex_bytes(tokens, lineno)
        if data:
            chunks.append(Chunk(data, direction))
    return chunks


def _field(record: Mapping[str, Any], *names: str) -> Any:
    for name in names:
        if name in record:
            return record[name]
    return None


def parse_trace(text: str) -> list[Chunk]:
    """Chunks from a JSON-lines wire trace (the client's ``trace=`` file)."""
    chunks: list[Chunk] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except json.JSONDecodeError as error:
            raise UsageError(f"line {lineno} of the trace is not JSON: {error.msg}") from None
        if not isinstance(record, dict):
            raise UsageError(f"line {lineno} of the trace is not a JSON object")
        raw = _field(record, "hex", "data", "bytes", "raw")
        if not isinstance(raw, str):
            raise UsageError(f"line {lineno} of the trace has no hex bytes")
        try:
            data = bytes.fromhex(raw.replace(":", " "))
        except ValueError:
            raise UsageError(f"line {lineno} of the trace: {raw!r} is not hex") from None
        word = _field(record, "direction", "dir", "to")
        direction = parse_direction(str(word)) if word is not None else None
        when = _field(record, "time", "t", "ts", "timestamp")
        chunks.append(Chunk(data, direction, when if isinstance(when, int | float) else None))
    return chunks
