"""Global variables GR/GW (point, integer, float): manual byte vectors, variants, round trips."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.commands import COMMANDS, Command, Shape, decode_request
from robostar.commands.variables import (
    ReadGlobalFloat,
    ReadGlobalInt,
    ReadGlobalPoint,
    WriteGlobalFloat,
    WriteGlobalInt,
    WriteGlobalPoint,
)
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.frame import encode_packet
from robostar.types import ArmForm, CoordSystem, Point

from .checks import assert_decodes_to, assert_round_trip

channels = st.integers(1, 3)
coords10 = st.integers(-99_999_999, 999_999_999).map(lambda n: n / 1000)
point_indexes = st.integers(0, 1023)
value_indexes = st.integers(0, 499)
axes = st.integers(1, 6)
full_points = st.builds(
    Point,
    st.lists(coords10, min_size=6, max_size=6).map(tuple),
    st.sampled_from(ArmForm),
    st.booleans(),
)


def one_axis_points(arm: st.SearchStrategy[ArmForm]) -> st.SearchStrategy[Point]:
    return st.builds(Point, coords10.map(lambda v: (v,)), arm, st.booleans())


def field_error(exc: pytest.ExceptionInfo[FieldError], command: str, field: str, flag: int) -> None:
    assert (exc.value.command, exc.value.field, exc.value.flag) == (command, field, flag)
    assert field in str(exc.value)


AXES_6 = (
    b"   100.000" + b"   -20.500" + b"     0.000" + b"    90.000" + b"     0.000" + b"     0.000"
)
POINT_6 = Point((100.0, -20.5, 0.0, 90.0, 0.0, 0.0), ArmForm.NONE, True)

REQUESTS: list[tuple[Command[Any], bytes]] = [
    # Type, channel, coordinate system, axis, INDEX 5 bytes space-padded (the manual's "   45").
    (ReadGlobalPoint(1, 45), b"\xffGR" + b"0" + b"0" + b"0" + b"0" + b"   45"),
    (ReadGlobalPoint(2, 1023, CoordSystem.XY, 3), b"\xffGR" + b"0" + b"1" + b"1" + b"3" + b" 1023"),
    # Type, INDEX 4 bytes ("  45").
    (ReadGlobalInt(45), b"\xffGR" + b"1" + b"  45"),
    (ReadGlobalFloat(45), b"\xffGR" + b"2" + b"  45"),
    (ReadGlobalFloat(0), b"\xffGR" + b"2" + b"   0"),
    # All axes: 6 x 10 bytes + USED + ARM.
    (WriteGlobalPoint(1, 45, POINT_6), b"\xffGW" + b"0000" + b"   45" + AXES_6 + b"1" + b"2"),
    # One axis: 10 bytes + USED + ARM.
    (
        WriteGlobalPoint(3, 7, Point((12345.123,), ArmForm.LEFT, True), CoordSystem.XY, 1),
        b"\xffGW" + b"0211" + b"    7" + b" 12345.123" + b"1" + b"0",
    ),
    # The manual's integer "123456" and float "123456.123".
    (WriteGlobalInt(45, 123456), b"\xffGW" + b"1" + b"  45" + b"123456"),
    (WriteGlobalInt(499, -99999), b"\xffGW" + b"1" + b" 499" + b"-99999"),
    (WriteGlobalInt(1, 5), b"\xffGW" + b"1" + b"   1" + b"     5"),
    (WriteGlobalFloat(45, 123456.123), b"\xffGW" + b"2" + b"  45" + b"123456.123"),
    (WriteGlobalFloat(45, -1.5), b"\xffGW" + b"2" + b"  45" + b"    -1.500"),
]


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_encodes_to_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert command.encode() == data


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_decodes_from_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert_decodes_to(command, data)


def test_receivers_accept_the_manuals_left_aligned_value_and_zero_padding() -> None:
    # The manual's one-axis table shows "12345.123" then a space.
    data = b"\xffGW" + b"0001" + b"   45" + b"12345.123 " + b"1" + b"2"
    assert decode_request(data) == WriteGlobalPoint(1, 45, Point((12345.123,)), axis=1)
    assert decode_request(b"\xffGR0000" + b"00045") == ReadGlobalPoint(1, 45)
    assert decode_request(b"\xffGR1" + b"0045") == ReadGlobalInt(45)
    assert decode_request(b"\xffGW1" + b"0045" + b"000012") == WriteGlobalInt(45, 12)


def test_framed_packets_carry_the_lrc() -> None:
    assert encode_packet(ReadGlobalPoint(1, 45).encode()) == b"\x02\xffGR0000   45\x03\xcb"
    assert encode_packet(ReadGlobalInt(45).encode()) == b"\x02\xffGR1  45\x03\xda"
    assert encode_packet(ReadGlobalInt(45).encode_answer(123456)[0]) == b"\x020123456\x03\x37"


def test_the_type_byte_picks_the_variant() -> None:
    assert set(COMMANDS["GR"]) == {ReadGlobalPoint, ReadGlobalInt, ReadGlobalFloat}
    assert set(COMMANDS["GW"]) == {WriteGlobalPoint, WriteGlobalInt, WriteGlobalFloat}
    assert type(decode_request(b"\xffGR0000   45")) is ReadGlobalPoint
    assert type(decode_request(b"\xffGR1  45")) is ReadGlobalInt
    assert type(decode_request(b"\xffGR2  45")) is ReadGlobalFloat
    for data in (b"\xffGR3  45", b"\xffGW9  45123456", b"\xffGR"):
        with pytest.raises(FieldError) as exc:
            decode_request(data)
        assert exc.value.flag == 0x31


@pytest.mark.parametrize(
    ("cls", "changes_state"),
    [
        (ReadGlobalPoint, False),
        (ReadGlobalInt, False),
        (ReadGlobalFloat, False),
        (WriteGlobalPoint, True),
        (WriteGlobalInt, True),
        (WriteGlobalFloat, True),
    ],
)
def test_class_attributes(cls: type[Command[Any]], changes_state: bool) -> None:
    assert cls.SHAPE is Shape.SINGLE
    assert cls.CHANGES_STATE is changes_state
    assert cls.ANSWER_DUMMY is False
    assert (cls.__doc__ or "").startswith(f"{cls.CODE} (Type ")


# -- answers ---------------------------------------------------------------------------------


def test_gr_point_answer_all_axes_both_ways() -> None:
    # FLAG, '0', 6 x 10 bytes, USED, ARM: 62 bytes of data.
    answer = [b"0" + b"0" + AXES_6 + b"1" + b"2"]
    assert ReadGlobalPoint(1, 45).decode_answer(answer) == POINT_6
    assert ReadGlobalPoint(1, 45).encode_answer(POINT_6) == answer
    assert len(answer[0]) == 1 + 1 + 62
    # A point with fewer axes is padded with 0.0 to six.
    short = Point((100.0, -20.5, 0.0, 90.0), ArmForm.NONE, True)
    assert ReadGlobalPoint(1, 45).encode_answer(short) == answer


def test_gr_point_answer_one_axis_both_ways() -> None:
    # The manual's example: "12345.123" then a space, then USED; 11 bytes, no ARM.
    command = ReadGlobalPoint(1, 45, axis=1)
    value = Point((12345.123,), ArmForm.NONE, True)
    assert command.decode_answer([b"0" + b"0" + b"12345.123 " + b"1"]) == value
    assert command.encode_answer(value) == [b"0" + b"0" + b" 12345.123" + b"1"]
    assert command.decode_answer([b"0" + b"0" + b"    -0.500" + b"0"]) == Point((-0.5,), used=False)


def test_gr_point_answer_is_checked() -> None:
    with pytest.raises(MalformedAnswerError):
        ReadGlobalPoint(1, 45).decode_answer([b"0" + b"1" + AXES_6 + b"1" + b"2"])
    with pytest.raises(FieldError):
        ReadGlobalPoint(1, 45).decode_answer([b"0" + b"0" + AXES_6 + b"1"])
    with pytest.raises(FieldError):
        ReadGlobalPoint(1, 45, axis=2).decode_answer([b"0" + b"0" + b"    -0.500" + b"0" + b"2"])
    with pytest.raises(FieldError) as exc:
        ReadGlobalPoint(1, 45, axis=2).encode_answer(POINT_6)
    assert exc.value.field == "point"


def test_gr_int_answer_both_ways() -> None:
    assert ReadGlobalInt(45).decode_answer([b"0" + b"123456"]) == 123456
    assert ReadGlobalInt(45).encode_answer(123456) == [b"0" + b"123456"]
    assert ReadGlobalInt(45).decode_answer([b"0" + b"000045"]) == 45
    assert ReadGlobalInt(45).encode_answer(-5) == [b"0" + b"    -5"]
    with pytest.raises(FieldError):
        ReadGlobalInt(45).decode_answer([b"0" + b"12345"])
    with pytest.raises(FieldError) as exc:
        ReadGlobalInt(45).encode_answer(1_000_000)
    assert exc.value.field == "value"


def test_gr_float_answer_both_ways() -> None:
    assert ReadGlobalFloat(45).decode_answer([b"0" + b"12345.123"]) == 12345.123
    assert ReadGlobalFloat(45).encode_answer(12345.123) == [b"0" + b"12345.123"]
    assert ReadGlobalFloat(45).encode_answer(-1.25) == [b"0" + b"   -1.250"]


@pytest.mark.parametrize(
    ("body", "value"),
    [
        (b"123456.123", 123456.123),  # 10 bytes: a value GW accepted (issue #19)
        (b"12345.123 ", 12345.123),  # left-aligned, as the manual draws it
        (b"+0012.5", 12.5),  # explicit sign, leading zeros, fewer decimals
        (b"  -1.250", -1.25),
        (b"7", 7.0),
    ],
)
def test_gr_float_is_read_in_any_width_and_padding(body: bytes, value: float) -> None:
    assert ReadGlobalFloat(45).decode_answer([b"0" + body]) == value


def test_gr_float_sends_nine_bytes_and_ten_only_when_needed() -> None:
    assert ReadGlobalFloat(45).encode_answer(123456.0) == [b"0" + b"123456.000"]
    with pytest.raises(FieldError) as exc:
        ReadGlobalFloat(45).encode_answer(1234567.0)
    assert exc.value.field == "value"


@pytest.mark.parametrize("body", [b"", b"12.3456", b"1 2", b"abc", b"1.2.3"])
def test_gr_float_that_is_not_a_number_is_refused(body: bytes) -> None:
    with pytest.raises((FieldError, MalformedAnswerError)):
        ReadGlobalFloat(45).decode_answer([b"0" + body])


@pytest.mark.parametrize(
    "command",
    [WriteGlobalPoint(1, 45, POINT_6), WriteGlobalInt(45, 1), WriteGlobalFloat(45, 1.0)],
)
def test_gw_answer_is_a_bare_flag(command: Command[None]) -> None:
    assert command.encode_answer(None) == [b"0"]
    assert command.decode_answer([b"0"]) is None
    with pytest.raises(FieldError):
        command.decode_answer([b"0" + b"0"])


@given(channels, point_indexes, st.sampled_from(CoordSystem), full_points)
def test_gr_point_all_axes_answer_round_trip(
    channel: int, index: int, coords: CoordSystem, point: Point
) -> None:
    command = ReadGlobalPoint(channel, index, coords)
    assert command.decode_answer(command.encode_answer(point)) == point


@given(axes, one_axis_points(st.just(ArmForm.NONE)))
def test_gr_point_one_axis_answer_round_trip(axis: int, point: Point) -> None:
    command = ReadGlobalPoint(1, 0, axis=axis)
    assert command.decode_answer(command.encode_answer(point)) == point


@given(st.integers(-99999, 999999))
def test_gr_int_answer_round_trip(value: int) -> None:
    assert ReadGlobalInt(1).decode_answer(ReadGlobalInt(1).encode_answer(value)) == value


@given(st.integers(-9_999_999, 99_999_999).map(lambda n: n / 1000))
def test_gr_float_answer_round_trip(value: float) -> None:
    assert ReadGlobalFloat(1).decode_answer(ReadGlobalFloat(1).encode_answer(value)) == value


# -- limits ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("command", "field"),
    [
        (ReadGlobalPoint(0, 45), "channel"),
        (ReadGlobalPoint(1, 1024), "index"),
        (ReadGlobalPoint(1, -1), "index"),
        (ReadGlobalPoint(1, 45, 2), "coords"),  # type: ignore[arg-type]
        (ReadGlobalPoint(1, 45, axis=7), "axis"),
        (ReadGlobalInt(500), "index"),
        (ReadGlobalFloat(-1), "index"),
        (WriteGlobalPoint(4, 45, POINT_6), "channel"),
        (WriteGlobalPoint(1, 1024, POINT_6), "index"),
        (WriteGlobalPoint(1, 45, POINT_6, axis=2), "point"),
        (WriteGlobalPoint(1, 45, Point((1.0,) * 7)), "point axis count"),
        (WriteGlobalPoint(1, 45, Point((1e6,) * 6)), "point axis 1"),
        (WriteGlobalPoint(1, 45, (1.0,) * 6), "point"),  # type: ignore[arg-type]
        (WriteGlobalInt(500, 1), "index"),
        (WriteGlobalInt(1, 1_000_000), "value"),
        (WriteGlobalInt(1, -100_000), "value"),
        (WriteGlobalInt(1, 1.5), "value"),  # type: ignore[arg-type]
        (WriteGlobalFloat(1, 1_000_000.0), "value"),
        (WriteGlobalFloat(1, -100_000.0), "value"),
        (WriteGlobalFloat(1, float("nan")), "value"),
        (WriteGlobalFloat(500, 1.0), "index"),
    ],
)
def test_range_errors_name_the_field(command: Command[Any], field: str) -> None:
    with pytest.raises(FieldError) as exc:
        command.encode()
    field_error(exc, "GR" if "Read" in type(command).__name__ else "GW", field, 0x31)


@pytest.mark.parametrize(
    ("data", "field"),
    [
        (b"\xffGR0300   45", "channel"),
        (b"\xffGR0020   45", "coords"),
        (b"\xffGR0007   45", "axis"),
        (b"\xffGR0000 1024", "index"),
        (b"\xffGR0000   4", "index"),
        (b"\xffGR1 500", "index"),
        (b"\xffGR2  4x", "index"),
        (b"\xffGW1  45123x56", "value"),
        (b"\xffGW2  4512345.1", "value"),
        (b"\xffGW0001   45" + b"     1.000" + b"1", "ARM"),
        (b"\xffGW0001   45" + b"     1.000" + b"2" + b"0", "USED"),
        (b"\xffGR1  45" + b"0", "packet"),
    ],
)
def test_controller_side_errors_name_the_field(data: bytes, field: str) -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(data)
    field_error(exc, data[1:3].decode(), field, 0x31)


# -- request round trips ---------------------------------------------------------------------

any_variable_command = st.one_of(
    st.builds(
        ReadGlobalPoint, channels, point_indexes, st.sampled_from(CoordSystem), st.integers(0, 6)
    ),
    st.builds(ReadGlobalInt, value_indexes),
    st.builds(ReadGlobalFloat, value_indexes),
    st.builds(
        WriteGlobalPoint,
        channels,
        point_indexes,
        full_points,
        st.sampled_from(CoordSystem),
        st.just(0),
    ),
    st.builds(
        WriteGlobalPoint,
        channels,
        point_indexes,
        one_axis_points(st.sampled_from(ArmForm)),
        st.sampled_from(CoordSystem),
        axes,
    ),
    st.builds(WriteGlobalInt, value_indexes, st.integers(-99999, 999999)),
    st.builds(
        WriteGlobalFloat,
        value_indexes,
        st.integers(-99_999_999, 999_999_999).map(lambda n: n / 1000),
    ),
)


@given(any_variable_command)
def test_request_round_trip(command: Command[Any]) -> None:
    assert_round_trip(command)


def test_gw_point_pads_missing_axes_with_zero() -> None:
    # The manual: on a 4-axis channel, send "0.0" for axes 5 and 6.
    command = WriteGlobalPoint(1, 45, Point((1.0, 2.0, 3.0, 4.0), ArmForm.LEFT))
    decoded = decode_request(command.encode())
    assert isinstance(decoded, WriteGlobalPoint)
    assert decoded.point == Point((1.0, 2.0, 3.0, 4.0, 0.0, 0.0), ArmForm.LEFT)
    assert len(command.encode()) == 3 + 4 + 5 + 62
