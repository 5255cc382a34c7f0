"""Motion commands BA-BG: byte vectors from the manual, round trips, and range checks."""

from __future__ import annotations

import string

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.commands import Command, Shape, decode_request
from robostar.commands.motion import (
    Home,
    JogContinue,
    JogStart,
    JogStop,
    Move,
    MoveBy,
    MoveToPoint,
)
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import FileName
from robostar.protocol.frame import encode_packet
from robostar.types import CoordSystem, JogDirection, MotionType

from .checks import assert_class_attributes, assert_decodes_to, assert_round_trip

# -- strategies ------------------------------------------------------------------------------

channels = st.integers(1, 3)
# Values that fit 10 bytes with 3 decimals ("-99999.999"); k/1000 survives the text round trip.
coords_values = st.integers(-99_999_999, 99_999_999).map(lambda k: k / 1000)


def axis_values(n: int) -> st.SearchStrategy[tuple[float, ...]]:
    return st.lists(coords_values, min_size=n, max_size=n).map(tuple)


@st.composite
def pnt_names(draw: st.DrawFn) -> FileName:
    letters = draw(st.sampled_from([string.ascii_uppercase, string.ascii_lowercase]))
    stem = draw(st.text(alphabet=letters + string.digits + "_", min_size=1, max_size=5))
    return FileName(stem, draw(st.sampled_from(["PNT", "pnt"])))


@st.composite
def move_to_points(draw: st.DrawFn) -> MoveToPoint:
    motion = draw(st.sampled_from(MotionType))
    point = draw(st.integers(0, 9999))
    two_points = motion in (MotionType.ARC, MotionType.CIRCLE)
    point2 = draw(st.integers(0, 9999)) if two_points else 0
    return MoveToPoint(draw(channels), draw(pnt_names()), motion, point, point2)


@st.composite
def moves(draw: st.DrawFn) -> Move:
    motion = draw(st.sampled_from(MotionType))
    count = 2 if motion in (MotionType.ARC, MotionType.CIRCLE) else 1
    axes = draw(st.integers(1, 6))
    points = tuple(draw(axis_values(axes)) for _ in range(count))
    return Move(draw(channels), motion, draw(st.sampled_from(CoordSystem)), points)


@st.composite
def moves_by(draw: st.DrawFn) -> MoveBy:
    delta = draw(st.integers(1, 6).flatmap(axis_values))
    motion = draw(st.sampled_from([MotionType.JOINT, MotionType.LINEAR]))
    return MoveBy(draw(channels), motion, draw(st.sampled_from(CoordSystem)), delta)


jog_starts = st.builds(
    JogStart,
    channels,
    st.integers(1, 6),
    st.sampled_from(JogDirection),
    st.sampled_from([MotionType.JOINT, MotionType.LINEAR]),
)

any_motion_command = st.one_of(
    st.builds(Home, channels),
    move_to_points(),
    moves(),
    moves_by(),
    jog_starts,
    st.builds(JogContinue, channels),
    st.builds(JogStop, channels),
)


def field_error(exc: pytest.ExceptionInfo[FieldError], command: str, field: str, flag: int) -> None:
    assert (exc.value.command, exc.value.field, exc.value.flag) == (command, field, flag)
    assert field in str(exc.value)


# -- request byte vectors --------------------------------------------------------------------

REQUESTS: list[tuple[Command[None], bytes]] = [
    (Home(1), b"\xffBA0"),
    (Home(3), b"\xffBA2"),
    # The manual's BB examples: target point 5 ("0005" "0000"), and points 5 and 15.
    (
        MoveToPoint(1, FileName("P1", "PNT"), MotionType.JOINT, 5),
        b"\xffBB0" + b"      P1.PNT" + b"0" + b"0005" + b"0000",
    ),
    (
        MoveToPoint(2, FileName("pos", "pnt"), MotionType.LINEAR, 5, 0),
        b"\xffBB1" + b"     pos.pnt" + b"1" + b"0005" + b"0000",
    ),
    (
        MoveToPoint(3, FileName("P1", "PNT"), MotionType.ARC, 5, 15),
        b"\xffBB2" + b"      P1.PNT" + b"2" + b"0005" + b"0015",
    ),
    (
        MoveToPoint(1, FileName("AB_12", "PNT"), MotionType.CIRCLE, 5, 15),
        b"\xffBB0" + b"   AB_12.PNT" + b"3" + b"0005" + b"0015",
    ),
    # A 4-axis robot: 4 x 10 bytes, right-aligned, 3 decimals.
    (
        Move(2, MotionType.LINEAR, CoordSystem.XY, ((100.0, -123.45, 0.0, 90.0),)),
        b"\xffBC1" + b"1" + b"1" + b"   100.000" + b"  -123.450" + b"     0.000" + b"    90.000",
    ),
    (
        Move(1, MotionType.ARC, CoordSystem.ANGLE, ((1.0, 2.5), (-3.125, 4.0))),
        b"\xffBC0" + b"2" + b"0" + b"     1.000     2.500" + b"    -3.125     4.000",
    ),
    (
        Move(1, MotionType.CIRCLE, CoordSystem.XY, ((10.0,), (20.0,))),
        b"\xffBC0" + b"3" + b"1" + b"    10.000" + b"    20.000",
    ),
    (
        MoveBy(3, MotionType.JOINT, CoordSystem.ANGLE, (1.5, -2.0, 0.001)),
        b"\xffBD2" + b"0" + b"0" + b"     1.500" + b"    -2.000" + b"     0.001",
    ),
    (
        MoveBy(1, MotionType.LINEAR, CoordSystem.XY, (-99999.999,)),
        b"\xffBD0" + b"1" + b"1" + b"-99999.999",
    ),
    # BE axis is pendant 1-6 on the API, '0'-'5' on the wire.
    (JogStart(1, 1, JogDirection.MINUS, MotionType.JOINT), b"\xffBE0" + b"0" + b"0" + b"0"),
    (JogStart(3, 3, JogDirection.PLUS, MotionType.LINEAR), b"\xffBE2" + b"2" + b"1" + b"1"),
    (JogStart(2, 6, JogDirection.PLUS, MotionType.JOINT), b"\xffBE1" + b"5" + b"1" + b"0"),
    (JogContinue(1), b"\xffBF0"),
    (JogContinue(2), b"\xffBF1"),
    (JogStop(1), b"\xffBG0"),
    (JogStop(3), b"\xffBG2"),
]


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_encodes_to_the_manuals_bytes(command: Command[None], data: bytes) -> None:
    assert command.encode() == data


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_decodes_from_the_manuals_bytes(command: Command[None], data: bytes) -> None:
    assert_decodes_to(command, data)


def test_framed_packets_carry_the_lrc() -> None:
    # LRC = XOR of FF 'B' 'A' '0' = 0xCC.
    assert encode_packet(Home(1).encode()) == b"\x02\xffBA0\x03\xcc"
    assert encode_packet(JogStop(1).encode()) == b"\x02\xffBG0\x03\xca"
    bb = MoveToPoint(3, "P1.PNT", MotionType.ARC, 5, 15)
    assert encode_packet(bb.encode()) == b"\x02\xffBB2      P1.PNT200050015\x03\xfb"
    be = JogStart(3, 3, JogDirection.PLUS, MotionType.LINEAR)
    assert encode_packet(be.encode()) == b"\x02\xffBE2211\x03\xf8"


def test_move_to_point_takes_a_string_file_name() -> None:
    as_text = MoveToPoint(1, "P1.PNT", MotionType.JOINT, 5)
    assert as_text.file == FileName("P1", "PNT")
    assert as_text == MoveToPoint(1, FileName("P1", "PNT"), MotionType.JOINT, 5, 0)
    assert hash(as_text) == hash(MoveToPoint(1, FileName("P1", "PNT"), MotionType.JOINT, 5))


def test_receivers_accept_space_padded_numbers() -> None:
    data = b"\xffBB0      P1.PNT2   5  15"
    assert decode_request(data) == MoveToPoint(1, "P1.PNT", MotionType.ARC, 5, 15)
    data = b"\xffBD000" + b"1.5".ljust(10) + b"-2".ljust(10)
    assert decode_request(data) == MoveBy(1, MotionType.JOINT, CoordSystem.ANGLE, (1.5, -2.0))


# -- answers ---------------------------------------------------------------------------------

MOTION_CLASSES = [Home, MoveToPoint, Move, MoveBy, JogStart, JogContinue, JogStop]


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_answer_is_a_bare_flag_both_ways(command: Command[None], data: bytes) -> None:
    assert command.encode_answer(None) == [b"0"]
    assert command.decode_answer([b"0"]) is None
    # A receiver accepts an optional FF before the flag.
    assert command.decode_answer([b"\xff0"]) is None
    assert encode_packet(command.encode_answer(None)[0]) == b"\x02\x30\x03\x30"


def test_answer_with_a_body_or_extra_packets_is_refused() -> None:
    with pytest.raises(FieldError):
        Home(1).decode_answer([b"0X"])
    with pytest.raises(MalformedAnswerError):
        Home(1).decode_answer([b"0", b"0"])
    with pytest.raises(MalformedAnswerError):
        Home(1).decode_answer([b"4"])


@pytest.mark.parametrize("cls", MOTION_CLASSES)
def test_motion_commands_are_single_state_changing_without_answer_dummy(
    cls: type[Command[None]],
) -> None:
    assert cls.CODE[0] == "B"
    assert cls.SHAPE is Shape.SINGLE
    assert_class_attributes(cls, changes_state=True)


# -- round-trip properties -------------------------------------------------------------------


@given(any_motion_command)
def test_request_round_trip(command: Command[None]) -> None:
    assert_round_trip(command)


@given(moves())
def test_move_splits_its_data_by_the_motion_type(command: Move) -> None:
    decoded = Move.decode(command.encode())
    assert len(decoded.points) == (2 if command.motion >= MotionType.ARC else 1)
    assert {len(p) for p in decoded.points} == {len(command.points[0])}


@given(any_motion_command)
def test_answer_round_trip(command: Command[None]) -> None:
    assert command.decode_answer(command.encode_answer(None)) is None


# -- range checks: refused on encode ---------------------------------------------------------


@pytest.mark.parametrize("channel", [0, 4, -1, True])
def test_channel_out_of_range_is_refused(channel: int) -> None:
    for command in (
        Home(channel),
        MoveToPoint(channel, "P1.PNT", MotionType.JOINT, 1),
        Move(channel, MotionType.JOINT, CoordSystem.ANGLE, ((0.0,),)),
        MoveBy(channel, MotionType.JOINT, CoordSystem.ANGLE, (0.0,)),
        JogStart(channel, 1, JogDirection.PLUS, MotionType.JOINT),
        JogContinue(channel),
        JogStop(channel),
    ):
        with pytest.raises(FieldError) as exc:
            command.encode()
        field_error(exc, command.CODE, "channel", 0x31)


@pytest.mark.parametrize("axis", [0, 7])
def test_jog_axis_out_of_range_is_refused(axis: int) -> None:
    with pytest.raises(FieldError) as exc:
        JogStart(1, axis, JogDirection.PLUS, MotionType.JOINT).encode()
    field_error(exc, "BE", "axis", 0x31)


def test_jog_direction_and_motion_are_checked() -> None:
    with pytest.raises(FieldError) as exc:
        JogStart(1, 1, 2, MotionType.JOINT).encode()  # type: ignore[arg-type]
    field_error(exc, "BE", "direction", 0x31)
    with pytest.raises(FieldError) as exc:
        JogStart(1, 1, JogDirection.PLUS, MotionType.ARC).encode()
    field_error(exc, "BE", "motion", 0x31)


@pytest.mark.parametrize(
    ("name", "flag"),
    [
        ("ABCDEF.PNT", 0x32),  # over 5 characters
        ("Ab.PNT", 0x31),  # mixed case
        ("AB.JOB", 0x31),  # a JOB file where a PNT file is needed
        ("AB.TXT", 0x31),  # unknown extension
        ("AB", 0x31),  # no extension
        ("", 0x31),
    ],
)
def test_bb_file_name_flags(name: str, flag: int) -> None:
    with pytest.raises(FieldError) as exc:
        MoveToPoint(1, name, MotionType.JOINT, 1).encode()
    field_error(exc, "BB", "file", flag)


def test_bb_point_numbers_are_checked() -> None:
    with pytest.raises(FieldError) as exc:
        MoveToPoint(1, "P1.PNT", MotionType.JOINT, 10000).encode()
    field_error(exc, "BB", "point", 0x31)
    with pytest.raises(FieldError) as exc:
        MoveToPoint(1, "P1.PNT", MotionType.ARC, 1, -1).encode()
    field_error(exc, "BB", "point2", 0x31)
    # A one-point move sends "0000" as Point Num 2.
    with pytest.raises(FieldError) as exc:
        MoveToPoint(1, "P1.PNT", MotionType.LINEAR, 1, 2).encode()
    field_error(exc, "BB", "point2", 0x31)
    with pytest.raises(FieldError) as exc:
        MoveToPoint(1, "P1.PNT", 4, 1).encode()  # type: ignore[arg-type]
    field_error(exc, "BB", "motion", 0x31)


def test_bc_motion_and_coordinate_system_are_checked() -> None:
    with pytest.raises(FieldError) as exc:
        Move(1, 7, CoordSystem.XY, ((0.0,),)).encode()  # type: ignore[arg-type]
    field_error(exc, "BC", "motion", 0x33)
    with pytest.raises(FieldError) as exc:
        Move(1, MotionType.JOINT, 2, ((0.0,),)).encode()  # type: ignore[arg-type]
    field_error(exc, "BC", "coords", 0x31)


@pytest.mark.parametrize(
    ("motion", "points"),
    [
        (MotionType.JOINT, ()),
        (MotionType.JOINT, ((1.0,), (2.0,))),
        (MotionType.ARC, ((1.0,),)),
        (MotionType.CIRCLE, ((1.0,), (2.0,), (3.0,))),
        (MotionType.ARC, ((1.0, 2.0), (3.0,))),
    ],
)
def test_bc_point_count_and_axes_must_match_the_motion(
    motion: MotionType, points: tuple[tuple[float, ...], ...]
) -> None:
    with pytest.raises(FieldError) as exc:
        Move(1, motion, CoordSystem.XY, points).encode()
    field_error(exc, "BC", "points", 0x31)


def test_bc_axis_values_are_checked() -> None:
    with pytest.raises(FieldError) as exc:
        Move(1, MotionType.JOINT, CoordSystem.XY, ((0.0,) * 7,)).encode()
    field_error(exc, "BC", "point 1 axis count", 0x31)
    with pytest.raises(FieldError) as exc:
        Move(1, MotionType.JOINT, CoordSystem.XY, ((),)).encode()
    field_error(exc, "BC", "point 1 axis count", 0x31)
    with pytest.raises(FieldError) as exc:
        Move(1, MotionType.ARC, CoordSystem.XY, ((0.0,), (1_000_000.0,))).encode()
    field_error(exc, "BC", "point 2 axis 1", 0x31)
    with pytest.raises(FieldError) as exc:
        Move(1, MotionType.JOINT, CoordSystem.XY, ((0.0, float("nan")),)).encode()
    field_error(exc, "BC", "point 1 axis 2", 0x31)
    with pytest.raises(FieldError) as exc:
        Move(1, MotionType.JOINT, CoordSystem.XY, "12").encode()  # type: ignore[arg-type]
    field_error(exc, "BC", "points", 0x31)


def test_bd_takes_joint_or_linear_only() -> None:
    with pytest.raises(FieldError) as exc:
        MoveBy(1, MotionType.ARC, CoordSystem.ANGLE, (1.0,)).encode()
    field_error(exc, "BD", "motion", 0x33)
    with pytest.raises(FieldError) as exc:
        MoveBy(1, MotionType.JOINT, 5, (1.0,)).encode()  # type: ignore[arg-type]
    field_error(exc, "BD", "coords", 0x31)
    with pytest.raises(FieldError) as exc:
        MoveBy(1, MotionType.JOINT, CoordSystem.ANGLE, ()).encode()
    field_error(exc, "BD", "delta axis count", 0x31)


# -- range checks: met in a request (controller side) ----------------------------------------


@pytest.mark.parametrize(
    ("data", "field", "flag"),
    [
        (b"\xffBA3", "channel", 0x31),
        (b"\xffBAx", "channel", 0x31),
        (b"\xffBA", "channel", 0x31),
        (b"\xffBB0    ABCDEF.PNT100010000", "file", 0x32),
        (b"\xffBB0      Ab.PNT100010000", "file", 0x31),
        (b"\xffBB0      AB.JOB100010000", "file", 0x31),
        (b"\xffBB0      AB.PNT400010000", "motion", 0x31),
        (b"\xffBB0      AB.PNT100010002", "point2", 0x31),
        (b"\xffBB0      AB.PNT1000x0000", "point", 0x31),
        (b"\xffBC07" + b"     1.000", "motion", 0x33),
        (b"\xffBC0x0" + b"     1.000", "motion", 0x33),
        (b"\xffBC002" + b"     1.000", "coords", 0x31),
        (b"\xffBC000" + b"     1.000" + b"12345", "points", 0x31),
        (b"\xffBC000", "points", 0x31),
        (b"\xffBC020" + b"     1.000" * 3, "points", 0x31),
        (b"\xffBC000" + b"     1.000" * 7, "points", 0x31),
        (b"\xffBC000" + b"     1.0x0", "point 1 axis 1", 0x31),
        (b"\xffBD020" + b"     1.000", "motion", 0x33),
        (b"\xffBD030" + b"     1.000", "motion", 0x33),
        (b"\xffBD002" + b"     1.000", "coords", 0x31),
        (b"\xffBD00" + b"0" + b"     1.0", "delta", 0x31),
        (b"\xffBD000" + b"     1.0x0", "delta axis 1", 0x31),
        (b"\xffBC020" + b"     1.000" + b"       1.x", "point 2 axis 1", 0x31),
        (b"\xffBE0600", "axis", 0x31),
        (b"\xffBE0020", "direction", 0x31),
        (b"\xffBE0002", "motion", 0x31),
        (b"\xffBF9", "channel", 0x31),
        (b"\xffBG3", "channel", 0x31),
    ],
)
def test_bad_request_fields_carry_the_controllers_flag(data: bytes, field: str, flag: int) -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(data)
    field_error(exc, data[1:3].decode(), field, flag)


def test_trailing_bytes_in_a_request_are_refused() -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffBA00")
    assert exc.value.field == "packet"
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffBE00000")
    assert exc.value.field == "packet"
