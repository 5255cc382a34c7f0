"""Tests of the field codecs: widths, padding, ranges, names, bit bytes and the Reader."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.errors import FieldError
from robostar.protocol.fields import (
    COORD_WIDTH,
    FLAG_FAILED,
    FLAG_REJECTED,
    FileName,
    NameProblem,
    Reader,
    check_channel,
    check_range,
    decode_io_nibbles,
    decode_using_axes,
    encode_channel,
    encode_code,
    encode_coord,
    encode_int,
    encode_io_nibbles,
    encode_pulse,
    encode_text,
    encode_using_axes,
    parse_coord,
    parse_int,
)
from robostar.types import ChannelStatus, MotionType


def field_error(call: object, *args: object, **kwargs: object) -> FieldError:
    with pytest.raises(FieldError) as info:
        call(*args, **kwargs)  # type: ignore[operator]
    return info.value


# -- ranges and codes ---------------------------------------------------------------------------
def test_check_range_passes_values_inside() -> None:
    assert check_range("CB", "speed", 0, 0, 1000) == 0
    assert check_range("CB", "speed", 1000, 0, 1000) == 1000


@pytest.mark.parametrize("value", [-1, 1001])
def test_check_range_refuses_values_outside_naming_the_field(value: int) -> None:
    error = field_error(check_range, "CB", "speed", value, 0, 1000)
    assert (error.command, error.field, error.flag) == ("CB", "speed", FLAG_REJECTED)
    assert str(value) in str(error)
    assert "0..1000" in str(error)


@pytest.mark.parametrize("value", [True, 1.0, "5", None])
def test_check_range_refuses_non_integers(value: object) -> None:
    error = field_error(check_range, "CB", "speed", value, 0, 1000)
    assert error.field == "speed"
    assert "integer" in str(error)


def test_check_range_carries_the_flag_a_controller_answers() -> None:
    assert field_error(check_range, "FE", "name", 9, 0, 5, flag=FLAG_FAILED).flag == FLAG_FAILED


@pytest.mark.parametrize(("channel", "wire"), [(1, b"0"), (2, b"1"), (3, b"2")])
def test_channels_go_out_as_ascii_digits_from_zero(channel: int, wire: bytes) -> None:
    assert encode_channel("BA", channel) == wire
    assert check_channel("BA", channel) == channel
    assert Reader("BA", wire).channel() == channel


@pytest.mark.parametrize("channel", [0, 4, -1, True])
def test_bad_channels_are_refused_naming_the_field(channel: int) -> None:
    error = field_error(encode_channel, "BA", channel)
    assert (error.command, error.field) == ("BA", "channel")
    assert field_error(encode_channel, "FF", channel, "target channel").field == "target channel"


def test_codes_are_one_ascii_digit() -> None:
    assert encode_code("AC", "type", 2, 0, 2) == b"2"
    assert encode_code("BE", "motion", MotionType.LINEAR, 0, 3) == b"1"
    error = field_error(encode_code, "AC", "type", 3, 0, 2)
    assert (error.command, error.field) == ("AC", "type")


@pytest.mark.parametrize("value", ["1", 1.7, None, True])
def test_codes_refuse_what_is_not_an_integer_naming_the_field(value: object) -> None:
    # A caller's wrong type must come back as a FieldError naming the field, never as a bare
    # ValueError/TypeError from a conversion, nor silently truncated (1.7 -> "1").
    error = field_error(encode_code, "BE", "motion", value, 0, 3)
    assert (error.command, error.field) == ("BE", "motion")


# -- integers ---------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("value", "width", "pad", "wire"),
    [
        (500, 4, "0", b"0500"),
        (5, 4, "0", b"0005"),
        (27, 4, "0", b"0027"),
        (1, 3, "0", b"001"),
        (2, 2, "0", b"02"),
        (45, 5, " ", b"   45"),
        (45, 4, " ", b"  45"),
        (0, 6, " ", b"     0"),
        (-45, 6, " ", b"   -45"),
        (-45, 6, "0", b"   -45"),
        (9999, 4, "0", b"9999"),
    ],
)
def test_integers_fill_their_width(value: int, width: int, pad: str, wire: bytes) -> None:
    assert encode_int("XX", "n", value, width, pad=pad) == wire
    assert parse_int("XX", "n", wire) == value


@pytest.mark.parametrize(("value", "width"), [(10000, 4), (-1000, 4), (100, 2), (1234567, 6)])
def test_integers_that_do_not_fit_are_refused_naming_the_field(value: int, width: int) -> None:
    error = field_error(encode_int, "GW", "value", value, width)
    assert (error.command, error.field) == ("GW", "value")
    assert f"{width} bytes" in str(error)


def test_integer_range_is_checked_before_the_width() -> None:
    error = field_error(encode_int, "CB", "speed", 1001, 4, lo=0, hi=1000)
    assert "0..1000" in str(error)
    assert encode_int("CB", "speed", 1000, 4, lo=0, hi=1000) == b"1000"


@pytest.mark.parametrize("value", [1.0, "12", True, None])
def test_integers_refuse_other_types(value: object) -> None:
    assert field_error(encode_int, "CB", "speed", value, 4).field == "speed"


@pytest.mark.parametrize(
    ("wire", "value"),
    [(b"0500", 500), (b" 500", 500), (b"  45", 45), (b"0045", 45), (b"-045", -45), (b"+7", 7)],
)
def test_integers_decode_with_either_padding(wire: bytes, value: int) -> None:
    assert parse_int("CA", "speed", wire) == value


@pytest.mark.parametrize("wire", [b"", b"    ", b"4 5", b"12a", b"1.5", b"\xb5\x80", b"--1"])
def test_bad_integer_fields_name_the_field(wire: bytes) -> None:
    error = field_error(parse_int, "CA", "speed", wire)
    assert (error.command, error.field, error.flag) == ("CA", "speed", FLAG_REJECTED)
    assert field_error(parse_int, "FE", "job", wire, flag=FLAG_FAILED).flag == FLAG_FAILED


@given(st.integers(min_value=-(10**5) + 1, max_value=10**6 - 1), st.sampled_from(["0", " "]))
def test_integers_round_trip(value: int, pad: str) -> None:
    wire = encode_int("XX", "n", value, 6, pad=pad)
    assert len(wire) == 6
    assert parse_int("XX", "n", wire) == value


# -- coordinates and pulses ---------------------------------------------------------------------
@pytest.mark.parametrize(
    ("value", "wire"),
    [
        (-123.45, b"  -123.450"),
        (123.45, b"   123.450"),
        (0, b"     0.000"),
        (0.0, b"     0.000"),
        (-0.0, b"     0.000"),
        (-0.0001, b"     0.000"),
        (999999.999, b"999999.999"),
        (-99999.999, b"-99999.999"),
        (12, b"    12.000"),
        (1.0005, b"     1.000"),
    ],
)
def test_coordinates_are_right_aligned_with_three_decimals(value: float, wire: bytes) -> None:
    assert encode_coord("BC", "axis 1", value) == wire
    assert len(wire) == COORD_WIDTH


@pytest.mark.parametrize("value", [1000000.0, -100000.0, 999999.9996, 1e20])
def test_coordinates_that_do_not_fit_are_refused_naming_the_field(value: float) -> None:
    error = field_error(encode_coord, "BC", "axis 2", value)
    assert (error.command, error.field) == ("BC", "axis 2")
    assert "10 bytes" in str(error)


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_coordinates_must_be_finite(value: float) -> None:
    assert field_error(encode_coord, "BD", "axis 3", value).field == "axis 3"


@pytest.mark.parametrize("value", ["1.0", None, True, b"1"])
def test_coordinates_must_be_numbers(value: object) -> None:
    assert field_error(encode_coord, "BD", "axis 3", value).field == "axis 3"


def test_coordinate_width_can_be_given() -> None:
    assert encode_coord("GW", "value", 123456.123, 10) == b"123456.123"
    assert encode_coord("GR", "value", 12345.123, 9) == b"12345.123"
    assert field_error(encode_coord, "GR", "value", 123456.123, 9).field == "value"


@pytest.mark.parametrize(
    ("wire", "value"),
    [
        (b"  -123.450", -123.45),
        (b"-00123.450", -123.45),
        (b"0000012.5 ", 12.5),
        (b"        12", 12.0),
        (b"       .5 ", 0.5),
        (b"      +1.0", 1.0),
        (b"     7.", 7.0),
    ],
)
def test_coordinates_decode_with_spaces_or_zeros(wire: bytes, value: float) -> None:
    assert parse_coord("AC", "axis 1", wire) == pytest.approx(value)


@pytest.mark.parametrize("wire", [b"", b"          ", b"  12.3.4  ", b"   1e5    ", b"  - 1.0   "])
def test_bad_coordinates_name_the_field(wire: bytes) -> None:
    error = field_error(parse_coord, "AC", "axis 4", wire)
    assert (error.command, error.field) == ("AC", "axis 4")


@given(st.floats(min_value=-99999.999, max_value=999999.999, allow_nan=False, allow_infinity=False))
def test_coordinates_round_trip_to_three_decimals(value: float) -> None:
    wire = encode_coord("BC", "axis 1", value)
    assert len(wire) == COORD_WIDTH
    assert wire == wire.rjust(COORD_WIDTH)
    assert abs(parse_coord("BC", "axis 1", wire) - value) <= 0.0005 + 1e-9


def test_pulses_are_space_padded_integers() -> None:
    assert encode_pulse("AC", "axis 1", 123456) == b"    123456"
    assert encode_pulse("AC", "axis 1", -5) == b"        -5"
    assert encode_pulse("AC", "axis 1", 0) == b"         0"
    assert field_error(encode_pulse, "AC", "axis 1", 10**10).field == "axis 1"
    assert field_error(encode_pulse, "AC", "axis 1", 1.5).field == "axis 1"


# -- text ---------------------------------------------------------------------------------------
def test_text_is_padded_with_spaces() -> None:
    assert encode_text("AD", "name", "N1", 6) == b"N1    "
    assert encode_text("AD", "name", "N1", 6, align=">") == b"    N1"
    assert encode_text("FB", "line", "MOVE\tP1\n", 8) == b"MOVE\tP1\n"


@pytest.mark.parametrize(("text", "why"), [("ABCDEFG", "longer"), ("ü", "ASCII"), ("A\x02", "")])
def test_bad_text_names_the_field(text: str, why: str) -> None:
    error = field_error(encode_text, "AD", "name", text, 6)
    assert (error.command, error.field) == ("AD", "name")
    assert why in str(error)


# -- file names ---------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("wire", "stem", "ext"),
    [
        (b"      RS.JOB", "RS", "JOB"),
        (b"RS.JOB      ", "RS", "JOB"),
        (b"  abc12.pnt ", "abc12", "pnt"),
        (b"   NOEXT    ", "NOEXT", ""),
        (b"A.B.JOB", "A.B", "JOB"),
    ],
)
def test_file_names_parse_with_spaces_removed(wire: bytes, stem: str, ext: str) -> None:
    name = Reader("FC", wire).name(len(wire))
    assert (name.stem, name.extension) == (stem, ext)
    assert FileName.parse(wire.decode()) == name


@pytest.mark.parametrize("text", ["RS.JOB", "rs.job", "A1_2.PNT", "abc.pnt", "12345.JOB", "1.job"])
def test_good_file_names(text: str) -> None:
    name = FileName.parse(text)
    assert name.problem() is None
    assert name.check("FC") is name
    assert str(name) == text


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("", NameProblem.EMPTY),
        (".JOB", NameProblem.EMPTY),
        ("ABCDEF.JOB", NameProblem.TOO_LONG),
        ("RsJob.JOB", NameProblem.MIXED_CASE),
        ("Ab.pnt", NameProblem.MIXED_CASE),
        ("A-B.JOB", NameProblem.BAD_CHARACTER),
        ("RS", NameProblem.NO_EXTENSION),
        ("RS.TXT", NameProblem.BAD_EXTENSION),
        ("RS.Job", NameProblem.BAD_EXTENSION),
    ],
)
def test_file_name_problems(text: str, problem: NameProblem) -> None:
    assert FileName.parse(text).problem() is problem


def test_a_name_over_five_characters_is_flag_0x32_whatever_the_case_flag() -> None:
    name = FileName.parse("ABCDEF.JOB")
    error = field_error(name.check, "DC", "file name", case_flag=FLAG_REJECTED)
    assert (error.command, error.field, error.flag) == ("DC", "file name", FLAG_FAILED)


@pytest.mark.parametrize("text", ["RsJob.JOB", "RS.TXT", "RS"])
@pytest.mark.parametrize("case_flag", [FLAG_REJECTED, FLAG_FAILED])
def test_mixed_case_and_bad_extension_take_the_case_flag(text: str, case_flag: int) -> None:
    error = field_error(FileName.parse(text).check, "BB", "point file", case_flag=case_flag)
    assert (error.field, error.flag) == ("point file", case_flag)
    assert text in str(error)


def test_case_flag_defaults_to_0x32() -> None:
    assert field_error(FileName.parse("RsJob.JOB").check, "FE").flag == FLAG_FAILED


def test_kind_restricts_the_extension() -> None:
    assert FileName.parse("RS.JOB").check("DC", kind="JOB").is_job
    assert FileName.parse("rs.job").check("DC", kind="JOB").is_job
    error = field_error(FileName.parse("RS.PNT").check, "DC", kind="JOB", case_flag=FLAG_REJECTED)
    assert (error.field, error.flag) == ("file name", FLAG_REJECTED)
    assert ".JOB" in str(error)


def test_name_kind_and_key() -> None:
    job = FileName.parse("rs.job")
    assert job.is_job and not job.is_points
    assert FileName.parse("P1.PNT").is_points
    assert job.key == FileName.parse("RS.JOB").key == "RS.JOB"


def test_names_encode_right_aligned_in_twelve_bytes() -> None:
    assert FileName("RS", "JOB").encode("FC", "file name") == b"      RS.JOB"
    assert FileName("RS", "JOB").encode("FH", "file name", 30, align="<") == b"RS.JOB" + b" " * 24
    assert FileName("rs", "job").encode("EF", "file name", align="<") == b"rs.job      "


# -- bit bytes ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("axes", "byte"),
    [((), 0x40), ((1,), 0x41), ((1, 2, 3), 0x47), ((1, 2, 3, 4, 5, 6), 0x7F), ((4,), 0x48)],
)
def test_using_axis_byte(axes: tuple[int, ...], byte: int) -> None:
    assert encode_using_axes("AD", axes) == bytes((byte,))
    assert decode_using_axes("AD", byte) == axes


@pytest.mark.parametrize("axis", [0, 7])
def test_using_axis_out_of_range(axis: int) -> None:
    assert field_error(encode_using_axes, "AD", [1, axis]).field == "axes in use"


@pytest.mark.parametrize("byte", [0x00, 0x07, 0x80, 0xC1, 0x30])
def test_using_axis_byte_needs_its_marker(byte: int) -> None:
    error = field_error(decode_using_axes, "AD", byte)
    assert (error.command, error.field) == ("AD", "axes in use")


def test_in0_is_the_first_bytes_high_bit() -> None:
    contacts = decode_io_nibbles("GA", b"\x38\x30\x30\x30")
    assert contacts[0] and sum(contacts) == 1
    assert decode_io_nibbles("GA", b"\x31\x30\x30\x30").index(True) == 3
    assert decode_io_nibbles("GA", b"\x30\x38\x30\x30").index(True) == 4
    assert decode_io_nibbles("GA", b"\x30\x30\x30\x31").index(True) == 15
    assert decode_io_nibbles("GA", b"\x3f\x3f\x3f\x3f") == (True,) * 16
    assert decode_io_nibbles("GA", b"0000") == (False,) * 16


def test_io_nibbles_encode() -> None:
    contacts = [False] * 16
    contacts[0] = contacts[5] = contacts[15] = True
    assert encode_io_nibbles(contacts) == bytes((0x38, 0x34, 0x30, 0x31))


@given(st.lists(st.booleans(), min_size=16, max_size=16))
def test_io_nibbles_round_trip(contacts: list[bool]) -> None:
    wire = encode_io_nibbles(contacts)
    assert all(b & 0xF0 == 0x30 for b in wire)
    assert decode_io_nibbles("GB", wire) == tuple(contacts)


@pytest.mark.parametrize("wire", [b"000", b"00000", b"\x40000", b"0\x0f00"])
def test_bad_io_bytes_name_the_field(wire: bytes) -> None:
    error = field_error(decode_io_nibbles, "GA", wire)
    assert (error.command, error.field) == ("GA", "contact states")


def test_io_nibbles_need_sixteen_contacts() -> None:
    assert field_error(encode_io_nibbles, [True] * 15).field == "contacts"


def test_status_byte_b5() -> None:
    status = Reader("AA", b"\xb5").status("channel 1")
    assert status == ChannelStatus(servo_on=True, origin=True, ready=True, running=True)
    assert status.to_byte() == 0xB5
    assert not status.alarm and not status.in_position


@given(st.integers(min_value=0x80, max_value=0xBF))
def test_every_status_byte_round_trips(byte: int) -> None:
    assert Reader("AA", bytes((byte,))).status("channel 1").to_byte() == byte


@pytest.mark.parametrize("byte", [0x00, 0x3F, 0x40, 0xC0, 0xFF])
def test_status_byte_needs_bit7_set_and_bit6_clear(byte: int) -> None:
    error = field_error(Reader("AA", bytes((byte,))).status, "channel 2")
    assert (error.command, error.field) == ("AA", "channel 2")


# -- Reader ---------------------------------------------------------------------------------------
def test_reader_walks_fields_in_order() -> None:
    reader = Reader("XX", b"\xff1" + b"0500" + b"  -123.450" + b"  45" + b"NAME  " + b"2")
    assert reader.byte("dummy") == 0xFF
    assert reader.channel() == 2
    assert reader.number(4, "speed", lo=0, hi=1000) == 500
    assert reader.coord("axis 1") == -123.45
    assert reader.number(4, "index") == 45
    assert reader.text(6, "name") == "NAME"
    assert reader.enum("motion", MotionType) is MotionType.ARC
    assert reader.remaining == 0
    reader.end()


def test_reader_rest_takes_everything_left() -> None:
    reader = Reader("KD", b"0Servo off", pos=1)
    assert reader.rest() == b"Servo off"
    assert reader.remaining == 0
    assert reader.rest() == b""


def test_reader_errors_name_the_field() -> None:
    short = Reader("AC", b"12")
    error = field_error(short.take, 3, "axis 1")
    assert (error.command, error.field) == ("AC", "axis 1")
    assert "needs 3 bytes, only 2 left" in str(error)
    assert field_error(Reader("AC", b"x").code, "type", 0, 2).field == "type"
    assert field_error(Reader("AC", b"3").code, "type", 0, 2).field == "type"
    assert field_error(Reader("BA", b"3").channel).field == "channel"
    assert field_error(Reader("CA", b"2000").number, 4, "speed", lo=0, hi=1000).field == "speed"
    assert field_error(Reader("CA", b"abcd").number, 4, "speed").field == "speed"
    assert field_error(Reader("AC", b"  12.x4   ").coord, "axis 2").field == "axis 2"
    assert field_error(Reader("BE", b"7").enum, "motion", MotionType).field == "motion"
    assert field_error(Reader("AA", b"").byte, "channel 1").field == "channel 1"


def test_reader_flags_travel_with_the_error() -> None:
    reader = Reader("FE", b"x")
    assert field_error(reader.code, "job", 0, 9, flag=FLAG_FAILED).flag == FLAG_FAILED
    error = field_error(Reader("FE", b"99").number, 2, "job", lo=0, hi=50, flag=FLAG_FAILED)
    assert error.flag == FLAG_FAILED


def test_reader_end_refuses_leftovers() -> None:
    reader = Reader("AA", b"\xb5\x80\x80X")
    for i in range(3):
        reader.status(f"channel {i + 1}")
    error = field_error(reader.end)
    assert (error.command, error.field) == ("AA", "packet")
    assert "1 unexpected" in str(error)


def test_reader_enum_with_holes() -> None:
    import enum

    class Odd(enum.IntEnum):
        ONE = 1
        THREE = 3

    assert Reader("XX", b"3").enum("kind", Odd) is Odd.THREE
    error = field_error(Reader("XX", b"2").enum, "kind", Odd)
    assert error.field == "kind"


def test_every_status_byte_decodes_equal_to_a_status_built_from_its_bits() -> None:
    # Statuses are handed out from a table made once: each must equal, field by field, the one
    # a caller would build, and stay a ChannelStatus that round-trips to its byte.
    for value in range(256):
        status = ChannelStatus.from_byte(value)
        assert type(status) is ChannelStatus
        assert status == ChannelStatus(
            servo_on=bool(value & 0x20),
            origin=bool(value & 0x10),
            alarm=bool(value & 0x08),
            ready=bool(value & 0x04),
            in_position=bool(value & 0x02),
            running=bool(value & 0x01),
        )
        assert status.to_byte() == 0x80 | (value & 0x3F)
        assert hash(status) == hash(ChannelStatus.from_byte(value & 0x3F))
