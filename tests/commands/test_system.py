"""System commands KD and KE: byte vectors from the manual, round trips, range checks."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.commands import Command, Shape, decode_request
from robostar.commands.system import ReadLastError, ReadParameters
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.frame import encode_packet

from .checks import assert_class_attributes, assert_decodes_to, assert_round_trip

printable = st.characters(min_codepoint=0x20, max_codepoint=0x7E)
ke_channels = st.sampled_from([1, 2, 3, None])
ke_indexes = st.sampled_from([-1]) | st.integers(1, 99)


def field_error(exc: pytest.ExceptionInfo[FieldError], command: str, field: str, flag: int) -> None:
    assert (exc.value.command, exc.value.field, exc.value.flag) == (command, field, flag)
    assert field in str(exc.value)


REQUESTS: list[tuple[Command[Any], bytes]] = [
    (ReadLastError(), b"\xffKD"),
    # Channel '0'-'2' for channels 1-3, '4' for the public parameters; INDEX 2 bytes (" 4").
    (ReadParameters(1, 4), b"\xffKE" + b"0" + b" 4"),
    (ReadParameters(3), b"\xffKE" + b"2" + b"-1"),
    (ReadParameters(None, 54), b"\xffKE" + b"4" + b"54"),
    (ReadParameters(None), b"\xffKE" + b"4" + b"-1"),
]


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_encodes_to_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert command.encode() == data


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_decodes_from_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert_decodes_to(command, data)


def test_framed_packets_carry_the_lrc() -> None:
    assert encode_packet(ReadLastError().encode()) == b"\x02\xffKD\x03\xf0"
    assert encode_packet(ReadParameters(1, 4).encode()) == b"\x02\xffKE0 4\x03\xd5"


def test_receivers_accept_a_zero_padded_index() -> None:
    assert decode_request(b"\xffKE1" + b"04") == ReadParameters(2, 4)


@pytest.mark.parametrize(
    ("cls", "shape"), [(ReadLastError, Shape.SINGLE), (ReadParameters, Shape.MULTI)]
)
def test_class_attributes(cls: type[Command[Any]], shape: Shape) -> None:
    assert cls.SHAPE is shape
    assert_class_attributes(cls, changes_state=False, dummy=True)


# -- KD --------------------------------------------------------------------------------------

LRC_TEXT = "LRC is different with received data LRC"


def test_kd_answer_both_ways() -> None:
    # The manual's example text.
    answer = [b"\xff0" + LRC_TEXT.encode()]
    assert ReadLastError().decode_answer(answer) == LRC_TEXT
    assert ReadLastError().encode_answer(LRC_TEXT) == answer
    assert ReadLastError().decode_answer([b"0" + b"port must be 2 digits  "]) == (
        "port must be 2 digits"
    )
    assert ReadLastError().decode_answer([b"\xff0"]) == ""


def test_kd_text_limits() -> None:
    assert len(ReadLastError().encode_answer("x" * 245)[0]) == 247
    for text in ("x" * 246, "é", "a\x03b"):
        with pytest.raises(FieldError) as exc:
            ReadLastError().encode_answer(text)
        assert exc.value.field == "text"
    with pytest.raises(MalformedAnswerError):
        ReadLastError().decode_answer([b"\xff0a", b"\xff0b"])


@given(st.text(alphabet=printable, max_size=245).map(str.strip))
def test_kd_answer_round_trip(text: str) -> None:
    assert ReadLastError().decode_answer(ReadLastError().encode_answer(text)) == text


# -- KE --------------------------------------------------------------------------------------


def test_ke_answer_both_ways() -> None:
    command = ReadParameters(1, -1)
    packets = [b"\xff0" + b"CONF 1 0 0", b"\xff0" + b"LENG  250.000", b"\xff4"]
    assert command.decode_answer(packets) == ("CONF 1 0 0", "LENG  250.000")
    assert command.encode_answer(("CONF 1 0 0", "LENG  250.000")) == packets
    assert command.decode_answer([b"\xff4"]) == ()
    with pytest.raises(MalformedAnswerError):
        command.decode_answer(packets[:-1])


def test_ke_data_limits() -> None:
    with pytest.raises(FieldError) as exc:
        ReadParameters(1).encode_answer(("ok", "x" * 246))
    assert exc.value.field == "data 2"


@given(st.lists(st.text(alphabet=printable | st.just("\t"), max_size=245), max_size=10))
def test_ke_answer_round_trip(data: list[str]) -> None:
    command = ReadParameters(None)
    assert command.decode_answer(command.encode_answer(tuple(data))) == tuple(data)


@pytest.mark.parametrize(
    ("command", "field"),
    [
        (ReadParameters(0), "channel"),
        (ReadParameters(4), "channel"),
        (ReadParameters(1, 0), "index"),
        (ReadParameters(1, 100), "index"),
        (ReadParameters(1, -2), "index"),
        (ReadParameters(None, 1.0), "index"),  # type: ignore[arg-type]
    ],
)
def test_ke_range_errors_name_the_field(command: ReadParameters, field: str) -> None:
    with pytest.raises(FieldError) as exc:
        command.encode()
    field_error(exc, "KE", field, 0x31)


@pytest.mark.parametrize(
    ("data", "field"),
    [
        (b"\xffKE3 4", "channel"),
        (b"\xffKE5 4", "channel"),
        (b"\xffKE0 0", "index"),
        (b"\xffKE0-2", "index"),
        (b"\xffKE0 x", "index"),
        (b"\xffKE0 4 ", "packet"),
    ],
)
def test_ke_controller_side_errors(data: bytes, field: str) -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(data)
    field_error(exc, "KE", field, 0x31)


def test_kd_request_has_no_fields() -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffKD0")
    assert exc.value.field == "packet"


@given(st.one_of(st.just(ReadLastError()), st.builds(ReadParameters, ke_channels, ke_indexes)))
def test_request_round_trip(command: Command[Any]) -> None:
    assert_round_trip(command)
