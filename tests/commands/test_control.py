"""Control commands CA-CZ: byte vectors from the manual, round trips, and range checks."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.commands import Command, Shape, decode_request
from robostar.commands.control import (
    EmergencyStop,
    ReadReferenceAxis,
    ReadSpeed,
    ResetAlarms,
    ResetJob,
    Restart,
    SetReferenceAxis,
    SetSpeed,
    StartJob,
    StopHoming,
    StopJob,
)
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.frame import encode_packet

from .checks import assert_class_attributes, assert_decodes_to, assert_round_trip

channels = st.integers(1, 3)

any_control_command = st.one_of(
    st.builds(ReadSpeed, channels),
    st.builds(SetSpeed, channels, st.integers(0, 1000)),
    st.builds(StartJob, channels),
    st.builds(StopJob, channels),
    st.builds(ResetJob, channels),
    st.just(EmergencyStop()),
    st.just(ResetAlarms()),
    st.builds(StopHoming, channels),
    st.just(Restart()),
    st.builds(SetReferenceAxis, channels, st.sampled_from([1, 4])),
    st.builds(ReadReferenceAxis, channels),
)


def field_error(exc: pytest.ExceptionInfo[FieldError], command: str, field: str, flag: int) -> None:
    assert (exc.value.command, exc.value.field, exc.value.flag) == (command, field, flag)
    assert field in str(exc.value)


# -- request byte vectors --------------------------------------------------------------------

REQUESTS: list[tuple[Command[Any], bytes]] = [
    (ReadSpeed(1), b"\xffCA0"),
    (ReadSpeed(3), b"\xffCA2"),
    # The manual's CB example writes speed 100 as "0100".
    (SetSpeed(1, 100), b"\xffCB0" + b"0100"),
    (SetSpeed(2, 1000), b"\xffCB1" + b"1000"),
    (SetSpeed(3, 0), b"\xffCB2" + b"0000"),
    (StartJob(1), b"\xffCC0"),
    (StartJob(2), b"\xffCC1"),
    (StopJob(3), b"\xffCD2"),
    (ResetJob(1), b"\xffCE0"),
    (ResetJob(2), b"\xffCE1"),
    (EmergencyStop(), b"\xffCF"),
    (ResetAlarms(), b"\xffCG"),
    (StopHoming(2), b"\xffCI1"),
    (Restart(), b"\xffCJ"),
    # CX sends the axis number itself, '1' (X) or '4' (W).
    (SetReferenceAxis(1, 1), b"\xffCX0" + b"1"),
    (SetReferenceAxis(3, 4), b"\xffCX2" + b"4"),
    # CZ: the manual's table misprints 'C' 'X'; the request is channel only.
    (ReadReferenceAxis(1), b"\xffCZ0"),
    (ReadReferenceAxis(2), b"\xffCZ1"),
]


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_encodes_to_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert command.encode() == data


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_decodes_from_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert_decodes_to(command, data)


def test_framed_packets_carry_the_lrc() -> None:
    # LRC = XOR of FF 'C' 'F' = 0xFA.
    assert encode_packet(EmergencyStop().encode()) == b"\x02\xffCF\x03\xfa"
    assert encode_packet(ResetAlarms().encode()) == b"\x02\xffCG\x03\xfb"
    assert encode_packet(Restart().encode()) == b"\x02\xffCJ\x03\xf6"
    assert encode_packet(SetSpeed(1, 100).encode()) == b"\x02\xffCB00100\x03\xcf"
    assert encode_packet(ReadSpeed(1).encode()) == b"\x02\xffCA0\x03\xcd"
    assert encode_packet(ReadReferenceAxis(2).encode()) == b"\x02\xffCZ1\x03\xd7"
    # The CA answer "0300": 0x30 ^ '0' ^ '3' ^ '0' ^ '0' = '3'.
    assert encode_packet(ReadSpeed(1).encode_answer(300)[0]) == b"\x020" + b"0300" + b"\x03\x33"


def test_receivers_accept_space_padded_speed() -> None:
    assert decode_request(b"\xffCB0" + b" 100") == SetSpeed(1, 100)
    assert ReadSpeed(1).decode_answer([b"0" + b" 300"]) == 300


# -- answers ---------------------------------------------------------------------------------


def test_ca_answer_is_four_digits() -> None:
    # The manual's CA example: speed 300 as "0300".
    assert ReadSpeed(1).decode_answer([b"0" + b"0300"]) == 300
    assert ReadSpeed(1).encode_answer(300) == [b"0" + b"0300"]
    assert ReadSpeed(2).encode_answer(1000) == [b"0" + b"1000"]
    assert ReadSpeed(2).decode_answer([b"\xff0" + b"0000"]) == 0


def test_ca_answer_out_of_range_or_short_is_refused() -> None:
    with pytest.raises(FieldError) as exc:
        ReadSpeed(1).decode_answer([b"0" + b"1001"])
    assert exc.value.field == "speed"
    with pytest.raises(FieldError) as exc:
        ReadSpeed(1).decode_answer([b"0" + b"030"])
    assert exc.value.field == "speed"
    with pytest.raises(FieldError) as exc:
        ReadSpeed(1).decode_answer([b"0" + b"03000"])
    assert exc.value.field == "packet"
    with pytest.raises(FieldError) as exc:
        ReadSpeed(1).encode_answer(1001)
    assert exc.value.field == "speed"


def test_cz_answer_is_one_digit_1_or_4() -> None:
    assert ReadReferenceAxis(1).decode_answer([b"0" + b"1"]) == 1
    assert ReadReferenceAxis(1).decode_answer([b"0" + b"4"]) == 4
    assert ReadReferenceAxis(1).encode_answer(4) == [b"0" + b"4"]
    assert ReadReferenceAxis(1).encode_answer(1) == [b"0" + b"1"]
    for bad in (b"0" + b"2", b"0" + b"0", b"0" + b"x", b"0"):
        with pytest.raises(FieldError) as exc:
            ReadReferenceAxis(1).decode_answer([bad])
        assert exc.value.field == "axis"
    with pytest.raises(FieldError) as exc:
        ReadReferenceAxis(1).encode_answer(2)
    assert exc.value.field == "axis"


def test_ce_answers_twice_with_a_bare_flag() -> None:
    command: Command[None] = ResetJob(1)
    assert command.SHAPE is Shape.TWO_PHASE
    assert command.encode_answer(None) == [b"0", b"0"]
    assert command.decode_answer([b"0", b"0"]) is None
    assert command.decode_answer([b"\xff0", b"0"]) is None


def test_ce_answer_needs_both_phases() -> None:
    with pytest.raises(MalformedAnswerError):
        ResetJob(1).decode_answer([b"0"])
    with pytest.raises(MalformedAnswerError):
        ResetJob(1).decode_answer([b"0", b"0", b"0"])
    with pytest.raises(FieldError):
        ResetJob(1).decode_answer([b"0", b"002"])


BARE_FLAG = [
    SetSpeed(1, 100),
    StartJob(1),
    StopJob(1),
    EmergencyStop(),
    ResetAlarms(),
    StopHoming(1),
    Restart(),
    SetReferenceAxis(1, 4),
]


@pytest.mark.parametrize("command", BARE_FLAG)
def test_single_answer_is_a_bare_flag_both_ways(command: Command[None]) -> None:
    assert command.SHAPE is Shape.SINGLE
    assert command.encode_answer(None) == [b"0"]
    assert command.decode_answer([b"0"]) is None
    assert command.decode_answer([b"\xff0"]) is None
    with pytest.raises(FieldError):
        command.decode_answer([b"0" + b"1"])
    with pytest.raises(MalformedAnswerError):
        command.decode_answer([b"0", b"0"])


@pytest.mark.parametrize(
    ("cls", "changes_state"),
    [
        (ReadSpeed, False),
        (SetSpeed, True),
        (StartJob, True),
        (StopJob, True),
        (ResetJob, True),
        (EmergencyStop, True),
        (ResetAlarms, True),
        (StopHoming, True),
        (Restart, True),
        (SetReferenceAxis, True),
        (ReadReferenceAxis, False),
    ],
)
def test_class_attributes(cls: type[Command[Any]], changes_state: bool) -> None:
    assert_class_attributes(cls, changes_state=changes_state, dummy=False)


# -- round-trip properties -------------------------------------------------------------------


@given(any_control_command)
def test_request_round_trip(command: Command[Any]) -> None:
    assert_round_trip(command)


@given(channels, st.integers(0, 1000))
def test_ca_answer_round_trip(channel: int, speed: int) -> None:
    command = ReadSpeed(channel)
    assert command.decode_answer(command.encode_answer(speed)) == speed


@given(channels, st.sampled_from([1, 4]))
def test_cz_answer_round_trip(channel: int, axis: int) -> None:
    command = ReadReferenceAxis(channel)
    assert command.decode_answer(command.encode_answer(axis)) == axis


@given(st.one_of(*(st.just(c) for c in BARE_FLAG), st.builds(ResetJob, channels)))
def test_bare_flag_answer_round_trip(command: Command[None]) -> None:
    assert command.decode_answer(command.encode_answer(None)) is None


# -- range checks ----------------------------------------------------------------------------


@pytest.mark.parametrize("channel", [0, 4, -1, True])
def test_channel_out_of_range_is_refused(channel: int) -> None:
    for command in (
        ReadSpeed(channel),
        SetSpeed(channel, 100),
        StartJob(channel),
        StopJob(channel),
        ResetJob(channel),
        StopHoming(channel),
        SetReferenceAxis(channel, 1),
        ReadReferenceAxis(channel),
    ):
        with pytest.raises(FieldError) as exc:
            command.encode()
        field_error(exc, command.CODE, "channel", 0x31)


@pytest.mark.parametrize("speed", [1001, -1, 10000])
def test_speed_out_of_range_is_refused(speed: int) -> None:
    with pytest.raises(FieldError) as exc:
        SetSpeed(1, speed).encode()
    field_error(exc, "CB", "speed", 0x31)


def test_speed_must_be_an_integer() -> None:
    with pytest.raises(FieldError) as exc:
        SetSpeed(1, 50.5).encode()  # type: ignore[arg-type]
    field_error(exc, "CB", "speed", 0x31)


@pytest.mark.parametrize("axis", [0, 2, 3, 5, 6, True, 1.0])
def test_reference_axis_other_than_1_or_4_is_refused(axis: int) -> None:
    with pytest.raises(FieldError) as exc:
        SetReferenceAxis(1, axis).encode()
    field_error(exc, "CX", "axis", 0x31)


@pytest.mark.parametrize(
    ("data", "field"),
    [
        (b"\xffCA3", "channel"),
        (b"\xffCB0" + b"1001", "speed"),
        (b"\xffCB0" + b"-001", "speed"),
        (b"\xffCB0" + b"01x0", "speed"),
        (b"\xffCB0" + b"100", "speed"),
        (b"\xffCC", "channel"),
        (b"\xffCD5", "channel"),
        (b"\xffCE3", "channel"),
        (b"\xffCI3", "channel"),
        (b"\xffCX0" + b"2", "axis"),
        (b"\xffCX0" + b"0", "axis"),
        (b"\xffCX0" + b"x", "axis"),
        (b"\xffCX0", "axis"),
        (b"\xffCZ3", "channel"),
        (b"\xffCF0", "packet"),
        (b"\xffCJ0", "packet"),
        (b"\xffCZ01", "packet"),
    ],
)
def test_bad_request_fields_are_rejected_with_0x31(data: bytes, field: str) -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(data)
    field_error(exc, data[1:3].decode(), field, 0x31)
