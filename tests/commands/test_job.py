"""Job commands DB, DC, EA, ED, EF: byte vectors from the manual, round trips, range checks."""

from __future__ import annotations

import string
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.commands import Command, Shape, decode_request
from robostar.commands.job import ReadJobName, ReadJobStep, SelectJob, Servo, SetJobMode
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import FileName
from robostar.protocol.frame import encode_packet
from robostar.types import JobMode

from .checks import assert_class_attributes, assert_decodes_to, assert_round_trip

channels = st.integers(1, 3)


@st.composite
def job_names(draw: st.DrawFn) -> FileName:
    letters = draw(st.sampled_from([string.ascii_uppercase, string.ascii_lowercase]))
    stem = draw(st.text(alphabet=letters + string.digits + "_", min_size=1, max_size=5))
    return FileName(stem, draw(st.sampled_from(["JOB", "job"])))


any_job_command = st.one_of(
    st.builds(Servo, channels, st.booleans()),
    st.builds(SelectJob, channels, job_names()),
    st.builds(SetJobMode, channels, st.sampled_from(JobMode)),
    st.builds(ReadJobStep, channels),
    st.builds(ReadJobName, channels),
)


def field_error(exc: pytest.ExceptionInfo[FieldError], command: str, field: str, flag: int) -> None:
    assert (exc.value.command, exc.value.field, exc.value.flag) == (command, field, flag)
    assert field in str(exc.value)


# -- request byte vectors --------------------------------------------------------------------

REQUESTS: list[tuple[Command[Any], bytes]] = [
    (Servo(1, True), b"\xffDB0" + b"1"),
    (Servo(3, False), b"\xffDB2" + b"0"),
    # 12 bytes: the name right-aligned, the rest spaces (0x20).
    (SelectJob(1, FileName("RS", "JOB")), b"\xffDC0" + b"      RS.JOB"),
    (SelectJob(2, FileName("main", "job")), b"\xffDC1" + b"    main.job"),
    (SelectJob(3, FileName("AB_12", "JOB")), b"\xffDC2" + b"   AB_12.JOB"),
    (SetJobMode(1, JobMode.AUTO), b"\xffEA0" + b"0"),
    (SetJobMode(2, JobMode.STEP), b"\xffEA1" + b"1"),
    (ReadJobStep(1), b"\xffED0"),
    (ReadJobStep(3), b"\xffED2"),
    (ReadJobName(1), b"\xffEF0"),
    (ReadJobName(2), b"\xffEF1"),
]


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_encodes_to_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert command.encode() == data


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_decodes_from_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert_decodes_to(command, data)


def test_framed_packets_carry_the_lrc() -> None:
    # LRC = XOR of FF 'D' 'B' '0' '1' = 0xF8.
    assert encode_packet(Servo(1, True).encode()) == b"\x02\xffDB01\x03\xf8"
    assert encode_packet(SelectJob(1, "RS.JOB").encode()) == b"\x02\xffDC0      RS.JOB\x03\xa0"
    assert encode_packet(ReadJobName(1).encode()) == b"\x02\xffEF0\x03\xcc"
    # DB's first answer "02": 0x30 ^ '0' ^ '2' = '2'.
    assert encode_packet(Servo(1, True).encode_answer(2)[0]) == b"\x02002\x03\x32"
    assert encode_packet(ReadJobStep(1).encode_answer(27)[0]) == b"\x0200027\x03\x35"
    name = FileName("RS", "JOB")
    assert encode_packet(ReadJobName(1).encode_answer(name)[0]) == b"\x020RS.JOB      \x03X"


def test_select_job_takes_a_string_file_name() -> None:
    assert SelectJob(1, "RS.JOB") == SelectJob(1, FileName("RS", "JOB"))
    assert SelectJob(1, "RS.JOB").file == FileName("RS", "JOB")


def test_receivers_accept_a_left_aligned_job_name() -> None:
    assert decode_request(b"\xffDC0" + b"RS.JOB      ") == SelectJob(1, "RS.JOB")


# -- answers ---------------------------------------------------------------------------------


@pytest.mark.parametrize("cls", [Servo, SelectJob])
def test_two_phase_answer_carries_the_expected_wait(cls: type[Command[int]]) -> None:
    command: Command[int] = Servo(1, True) if cls is Servo else SelectJob(1, "RS.JOB")
    assert command.SHAPE is Shape.TWO_PHASE
    # The manual's examples: an expected wait of 2 s ("02") and of 20 s ("20").
    assert command.decode_answer([b"0" + b"02", b"0"]) == 2
    assert command.decode_answer([b"0" + b"20", b"0"]) == 20
    assert command.decode_answer([b"\xff0" + b" 5", b"\xff0"]) == 5
    assert command.encode_answer(2) == [b"0" + b"02", b"0"]
    assert command.encode_answer(20) == [b"0" + b"20", b"0"]


@pytest.mark.parametrize("command", [Servo(1, True), SelectJob(1, "RS.JOB")])
def test_two_phase_answer_is_checked(command: Command[int]) -> None:
    with pytest.raises(MalformedAnswerError):
        command.decode_answer([b"0" + b"02"])
    with pytest.raises(MalformedAnswerError):
        command.decode_answer([b"0" + b"02", b"0", b"0"])
    with pytest.raises(MalformedAnswerError):
        command.decode_answer([b"0" + b"02", b"4"])
    with pytest.raises(FieldError) as exc:
        command.decode_answer([b"0", b"0"])
    assert exc.value.field == "expected wait"
    with pytest.raises(FieldError) as exc:
        command.decode_answer([b"0" + b"x2", b"0"])
    assert exc.value.field == "expected wait"
    with pytest.raises(FieldError) as exc:
        command.decode_answer([b"0" + b"02", b"0" + b"02"])
    assert exc.value.field == "packet"
    with pytest.raises(FieldError) as exc:
        command.encode_answer(100)
    assert exc.value.field == "expected wait"


def test_ed_answer_is_four_digits() -> None:
    # The manual's ED example: step 27 as "0027".
    assert ReadJobStep(1).decode_answer([b"0" + b"0027"]) == 27
    assert ReadJobStep(1).encode_answer(27) == [b"0" + b"0027"]
    assert ReadJobStep(1).encode_answer(9999) == [b"0" + b"9999"]
    with pytest.raises(FieldError) as exc:
        ReadJobStep(1).decode_answer([b"0" + b"027"])
    assert exc.value.field == "step"
    with pytest.raises(FieldError) as exc:
        ReadJobStep(1).encode_answer(10000)
    assert exc.value.field == "step"


def test_ef_answer_is_a_left_aligned_name() -> None:
    # The manual's EF example: "RS.JOB" then spaces to 12 bytes.
    name = FileName("RS", "JOB")
    assert ReadJobName(1).decode_answer([b"0" + b"RS.JOB      "]) == name
    assert ReadJobName(1).encode_answer(name) == [b"0" + b"RS.JOB      "]
    assert ReadJobName(1).encode_answer(FileName("main", "job")) == [b"0" + b"main.job    "]


def test_ef_answer_of_spaces_is_no_job() -> None:
    assert ReadJobName(1).decode_answer([b"0" + b" " * 12]) is None
    assert ReadJobName(1).encode_answer(None) == [b"0" + b" " * 12]


def test_ef_answer_of_the_wrong_size_is_refused() -> None:
    with pytest.raises(FieldError) as exc:
        ReadJobName(1).decode_answer([b"0" + b"RS.JOB"])
    assert exc.value.field == "file"
    with pytest.raises(FieldError) as exc:
        ReadJobName(1).decode_answer([b"0" + b"RS.JOB       "])
    assert exc.value.field == "packet"


def test_ea_answer_is_a_bare_flag() -> None:
    command: Command[None] = SetJobMode(1, JobMode.STEP)
    assert command.SHAPE is Shape.SINGLE
    assert command.encode_answer(None) == [b"0"]
    assert command.decode_answer([b"0"]) is None
    with pytest.raises(FieldError):
        command.decode_answer([b"0" + b"1"])


@pytest.mark.parametrize(
    ("cls", "changes_state"),
    [
        (Servo, True),
        (SelectJob, True),
        (SetJobMode, True),
        (ReadJobStep, False),
        (ReadJobName, False),
    ],
)
def test_class_attributes(cls: type[Command[Any]], changes_state: bool) -> None:
    assert_class_attributes(cls, changes_state=changes_state, dummy=False)


# -- round-trip properties -------------------------------------------------------------------


@given(any_job_command)
def test_request_round_trip(command: Command[Any]) -> None:
    assert_round_trip(command)


@given(channels, st.booleans(), st.integers(0, 99))
def test_servo_answer_round_trip(channel: int, on: bool, wait: int) -> None:
    command = Servo(channel, on)
    assert command.decode_answer(command.encode_answer(wait)) == wait


@given(channels, job_names(), st.integers(0, 99))
def test_select_job_answer_round_trip(channel: int, name: FileName, wait: int) -> None:
    command = SelectJob(channel, name)
    assert command.decode_answer(command.encode_answer(wait)) == wait


@given(channels, st.sampled_from(JobMode))
def test_set_job_mode_answer_round_trip(channel: int, mode: JobMode) -> None:
    command: Command[None] = SetJobMode(channel, mode)
    assert command.decode_answer(command.encode_answer(None)) is None


@given(channels, st.integers(0, 9999))
def test_job_step_answer_round_trip(channel: int, step: int) -> None:
    command = ReadJobStep(channel)
    assert command.decode_answer(command.encode_answer(step)) == step


@given(channels, st.none() | job_names())
def test_job_name_answer_round_trip(channel: int, name: FileName | None) -> None:
    command = ReadJobName(channel)
    assert command.decode_answer(command.encode_answer(name)) == name


# -- range checks ----------------------------------------------------------------------------


@pytest.mark.parametrize("channel", [0, 4, -1, True])
def test_channel_out_of_range_is_refused(channel: int) -> None:
    for command in (
        Servo(channel, True),
        SelectJob(channel, "RS.JOB"),
        SetJobMode(channel, JobMode.AUTO),
        ReadJobStep(channel),
        ReadJobName(channel),
    ):
        with pytest.raises(FieldError) as exc:
            command.encode()
        field_error(exc, command.CODE, "channel", 0x31)


@pytest.mark.parametrize("on", [1, 0, "1", None])
def test_servo_on_must_be_a_bool(on: Any) -> None:
    with pytest.raises(FieldError) as exc:
        Servo(1, on).encode()
    field_error(exc, "DB", "on", 0x31)


@pytest.mark.parametrize("mode", [2, -1, True])
def test_job_mode_out_of_range_is_refused(mode: Any) -> None:
    with pytest.raises(FieldError) as exc:
        SetJobMode(1, mode).encode()
    field_error(exc, "EA", "mode", 0x31)


@pytest.mark.parametrize(
    ("name", "flag"),
    [
        ("ABCDEF.JOB", 0x32),  # over 5 characters
        ("Rs.JOB", 0x31),  # mixed case
        ("RS.PNT", 0x31),  # a PNT file where a JOB file is needed
        ("RS.TXT", 0x31),
        ("RS", 0x31),
        ("R-S.JOB", 0x31),
    ],
)
def test_dc_file_name_flags(name: str, flag: int) -> None:
    with pytest.raises(FieldError) as exc:
        SelectJob(1, name).encode()
    field_error(exc, "DC", "file", flag)


def test_ef_answer_name_too_wide_is_refused() -> None:
    with pytest.raises(FieldError) as exc:
        ReadJobName(1).encode_answer(FileName("ABCDEFGHI", "JOB"))
    assert exc.value.field == "file"


@pytest.mark.parametrize(
    ("data", "field", "flag"),
    [
        (b"\xffDB3" + b"1", "channel", 0x31),
        (b"\xffDB0" + b"2", "on", 0x31),
        (b"\xffDB0", "on", 0x31),
        (b"\xffDC0" + b"  ABCDEF.JOB", "file", 0x32),
        (b"\xffDC0" + b"      Rs.JOB", "file", 0x31),
        (b"\xffDC0" + b"      RS.PNT", "file", 0x31),
        (b"\xffDC0" + b"RS.JOB", "file", 0x31),
        (b"\xffEA0" + b"2", "mode", 0x31),
        (b"\xffEA0" + b"x", "mode", 0x31),
        (b"\xffED3", "channel", 0x31),
        (b"\xffEF3", "channel", 0x31),
        (b"\xffEF00", "packet", 0x31),
    ],
)
def test_bad_request_fields_carry_the_controllers_flag(data: bytes, field: str, flag: int) -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(data)
    field_error(exc, data[1:3].decode(), field, flag)
