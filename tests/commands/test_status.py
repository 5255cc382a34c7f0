"""AA's answer read at once, pinned to the field-by-field reading it shortcuts."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.commands.status import ReadStatus
from robostar.errors import MalformedAnswerError


def _outcome(decode: object, packets: list[bytes]) -> object:
    try:
        return ("result", decode(packets))  # type: ignore[operator]
    except MalformedAnswerError as exc:
        return ("error", type(exc), str(exc), exc.raw)
    except Exception as exc:  # the same exception, whatever it is
        return ("error", type(exc), str(exc))


def _check(packets: list[bytes]) -> None:
    command = ReadStatus()
    assert _outcome(command.decode_answer, packets) == _outcome(command._decode_fields, packets)


# Every byte value in each position, the others good; and every flag and length around it.
_BYTES = [0x80, 0xB5, 0xBF, 0x00, 0x3F, 0x40, 0x7F, 0xC0, 0xFF, 0x30, 0x84]


@pytest.mark.parametrize("position", [1, 2, 3])
def test_every_status_byte_reads_as_field_by_field(position: int) -> None:
    for value in range(256):
        packet = bytearray(b"0\x84\x84\x80")
        packet[position] = value
        _check([bytes(packet)])


def test_answers_of_every_shape_read_as_field_by_field() -> None:
    for flag, a, b, c in itertools.product([0x30, 0x31, 0x34, 0xFF], _BYTES, _BYTES[:4], _BYTES):
        _check([bytes((flag, a, b, c))])
    for packet in (b"", b"0", b"0\x84", b"0\x84\x84", b"0\x84\x84\x80\x80", b"\xff0\x84\x84\x80"):
        _check([packet])
    _check([])
    _check([b"0\x84\x84\x80", b"0\x84\x84\x80"])


@given(st.lists(st.binary(max_size=6), max_size=2))
def test_any_answer_reads_as_field_by_field(packets: list[bytes]) -> None:
    _check(packets)
