"""An independent reader of Sparkplug B payloads for the tests: the protobuf wire format read by
hand with the field numbers of the Sparkplug 3.0 specification, not robostar's generated
module, so a wrong number or type in the schema robostar ships would show here."""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any


def _varint(data: bytes, at: int) -> tuple[int, int]:
    shift = result = 0
    while True:
        byte = data[at]
        at += 1
        result |= (byte & 0x7F) << shift
        if not byte & 0x80:
            return result, at
        shift += 7


def fields(data: bytes) -> list[tuple[int, int, Any]]:
    """(number, wire type, value) in order: varints as ints, 64/32-bit as bytes, the rest
    (length-delimited) as bytes."""
    out: list[tuple[int, int, Any]] = []
    at = 0
    while at < len(data):
        key, at = _varint(data, at)
        number, kind = key >> 3, key & 7
        value: Any
        if kind == 0:
            value, at = _varint(data, at)
        elif kind == 1:
            value, at = data[at : at + 8], at + 8
        elif kind == 5:
            value, at = data[at : at + 4], at + 4
        elif kind == 2:
            size, at = _varint(data, at)
            value, at = data[at : at + size], at + size
        else:
            raise ValueError(f"wire type {kind}")
        out.append((number, kind, value))
    return out


@dataclass
class Metric:
    name: str | None = None
    alias: int | None = None
    timestamp: int | None = None
    datatype: int | None = None
    is_null: bool = False
    is_historical: bool = False
    value: Any = None
    properties: dict[str, Any] = field(default_factory=dict)


@dataclass
class Payload:
    timestamp: int | None = None
    seq: int | None = None
    metrics: list[Metric] = field(default_factory=list)


def _properties(data: bytes) -> dict[str, Any]:
    keys: list[str] = []
    values: list[Any] = []
    for number, _, value in fields(data):
        if number == 1:
            keys.append(value.decode())
        elif number == 2:
            inner = {n: v for n, _, v in fields(value)}
            values.append(inner[8].decode() if 8 in inner else inner.get(3))
    return dict(zip(keys, values, strict=True))


def _metric(data: bytes) -> Metric:
    metric = Metric()
    for number, _, value in fields(data):
        if number == 1:
            metric.name = value.decode()
        elif number == 2:
            metric.alias = value
        elif number == 3:
            metric.timestamp = value
        elif number == 4:
            metric.datatype = value
        elif number == 5:
            metric.is_historical = bool(value)
        elif number == 7:
            metric.is_null = bool(value)
        elif number == 9:
            metric.properties = _properties(value)
        elif number in (10, 11):  # int_value, long_value (two's complement)
            metric.value = value - (1 << 64) if value >= 1 << 63 else value
        elif number == 13:
            metric.value = struct.unpack("<d", value)[0]
        elif number == 14:
            metric.value = bool(value)
        elif number == 15:
            metric.value = value.decode()
    return metric


def read(data: bytes) -> Payload:
    payload = Payload()
    for number, _, value in fields(data):
        if number == 1:
            payload.timestamp = value
        elif number == 2:
            payload.metrics.append(_metric(value))
        elif number == 3:
            payload.seq = value
    return payload


def rebirth_request() -> bytes:
    """An NCMD payload: the metric ``Node Control/Rebirth`` = true (Boolean, 11)."""
    name = b"Node Control/Rebirth"
    metric = bytes([0x0A, len(name)]) + name + bytes([0x20, 11, 0x70, 1])
    return bytes([0x12, len(metric)]) + metric


def command_request(name: str, text: str) -> bytes:
    """A DCMD payload: the String (12) metric ``name`` holding ``text``."""
    n, t = name.encode(), text.encode()
    metric = bytes([0x0A, len(n)]) + n + bytes([0x20, 12, 0x7A, len(t)]) + t
    return bytes([0x12, len(metric)]) + metric


def _varint_bytes(value: int) -> bytes:
    out = bytearray()
    value &= (1 << 64) - 1
    while True:
        byte, value = value & 0x7F, value >> 7
        out.append(byte | (0x80 if value else 0))
        if not value:
            return bytes(out)


def write_request(name: str, value: bool | int | str) -> bytes:
    """A DCMD payload writing metric ``name``: Boolean (11), Int64 (4) or String (12)."""
    n = name.encode()
    if isinstance(value, bool):
        typed = bytes([0x20, 11, 0x70, int(value)])
    elif isinstance(value, int):
        typed = bytes([0x20, 4, 0x58]) + _varint_bytes(value)
    else:
        t = value.encode()
        typed = bytes([0x20, 12, 0x7A, len(t)]) + t
    metric = bytes([0x0A, len(n)]) + n + typed
    return bytes([0x12, len(metric)]) + metric
