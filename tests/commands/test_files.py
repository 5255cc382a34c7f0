"""File commands FA-FH: byte vectors from the manual, integrity checks, round trips, limits."""

from __future__ import annotations

import string
from dataclasses import replace
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.commands import Command, Shape, decode_request
from robostar.commands.files import (
    CopyFile,
    DeleteFile,
    DownloadFile,
    FileExists,
    ListFiles,
    ReadAlarmHistory,
    RenameFile,
    UploadFile,
    format_point_line,
    parse_point_line,
)
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import FileName
from robostar.protocol.frame import encode_packet
from robostar.types import AlarmRecord, ArmForm, CoordSystem, FileRecord, JobFile, Point, PointFile

from .checks import assert_class_attributes, assert_decodes_to, assert_round_trip

channels = st.integers(1, 3)
# Values that fit 10 bytes with 3 decimals, exact in thousandths.
coords = st.integers(-99_999_999, 999_999_999).map(lambda n: n / 1000)
points = st.builds(
    Point,
    st.lists(coords, min_size=1, max_size=6).map(tuple),
    st.sampled_from(ArmForm),
    st.booleans(),
)
printable = st.characters(min_codepoint=0x20, max_codepoint=0x7E)
job_lines = st.text(
    alphabet=st.characters(min_codepoint=0x20, max_codepoint=0x7E) | st.just("\t"), max_size=99
)


@st.composite
def file_names(
    draw: st.DrawFn, extensions: tuple[str, ...] = ("JOB", "PNT", "job", "pnt")
) -> FileName:
    letters = draw(st.sampled_from([string.ascii_uppercase, string.ascii_lowercase]))
    stem = draw(st.text(alphabet=letters + string.digits + "_", min_size=1, max_size=5))
    return FileName(stem, draw(st.sampled_from(extensions)))


def field_error(exc: pytest.ExceptionInfo[FieldError], command: str, field: str, flag: int) -> None:
    assert (exc.value.command, exc.value.field, exc.value.flag) == (command, field, flag)
    assert field in str(exc.value)


RS_JOB = FileName("RS", "JOB")
RS_PNT = FileName("RS", "PNT")

# -- requests: the manual's tables -----------------------------------------------------------

REQUESTS: list[tuple[Command[Any], bytes]] = [
    # Channel '0', TYPE '0' (backup RAM), the name right-aligned in 12 bytes, PNT_TYPE.
    (DownloadFile(1, RS_JOB), b"\xffFA" + b"00" + b"      RS.JOB" + b"0"),
    (DownloadFile(3, RS_PNT, CoordSystem.XY), b"\xffFA" + b"20" + b"      RS.PNT" + b"1"),
    # Channel, TYPE, JOB number "001", name.
    (UploadFile(1, RS_JOB, 1), b"\xffFB" + b"00" + b"001" + b"      RS.JOB"),
    (UploadFile(2, "ab.job", 200), b"\xffFB" + b"10" + b"200" + b"      ab.job"),
    (FileExists(1, RS_JOB), b"\xffFC" + b"00" + b"      RS.JOB"),
    (ListFiles(1), b"\xffFD" + b"00" + b"           *"),
    (ListFiles(2, "*.*"), b"\xffFD" + b"10" + b"         *.*"),
    (ListFiles(1, "RS.JOB"), b"\xffFD" + b"00" + b"      RS.JOB"),
    # FE's trailing DATA is "planned": always '0'.
    (DeleteFile(1, RS_JOB), b"\xffFE" + b"00" + b"      RS.JOB" + b"0"),
    # FF: channel 1, TYPE, name 1, channel 2, name 2 ("TT.JOB" in the manual).
    (
        CopyFile(1, RS_JOB, 1, "TT.JOB"),
        b"\xffFF" + b"00" + b"      RS.JOB" + b"0" + b"      TT.JOB",
    ),
    # FG: name 1 in 13 bytes, the 13th a space separator; then name 2 ("T1.JOB").
    (RenameFile(1, RS_JOB, "T1.JOB"), b"\xffFG" + b"00" + b"      RS.JOB " + b"      T1.JOB"),
    # FH: TYPE then "alarm_history.txt" left-aligned in 30 bytes.
    (ReadAlarmHistory(), b"\xffFH" + b"0" + b"alarm_history.txt" + b" " * 13),
]


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_encodes_to_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert command.encode() == data


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_decodes_from_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert_decodes_to(command, data)


def test_framed_requests_carry_the_lrc() -> None:
    assert encode_packet(DownloadFile(1, "RS.JOB").encode()) == b"\x02\xffFA00      RS.JOB0\x03\xa0"
    assert (
        encode_packet(UploadFile(1, "RS.JOB", 1).encode()) == b"\x02\xffFB00001      RS.JOB\x03\xa2"
    )
    assert encode_packet(FileExists(1, "RS.JOB").encode()) == b"\x02\xffFC00      RS.JOB\x03\x92"
    assert encode_packet(ReadAlarmHistory().encode()) == (
        b"\x02\xffFH0alarm_history.txt" + b" " * 13 + b"\x03\xf9"
    )


def test_file_arguments_take_strings_and_keep_file_names() -> None:
    assert DownloadFile(1, "RS.JOB") == DownloadFile(1, RS_JOB)
    assert DownloadFile(1, "RS.JOB").file == RS_JOB
    assert CopyFile(1, "RS.JOB", 1, "TT.JOB").to_file == FileName("TT", "JOB")
    assert RenameFile(1, "RS.JOB", "T1.JOB").new_file == FileName("T1", "JOB")
    assert ListFiles(1, FileName("RS", "JOB")).pattern == "RS.JOB"


def test_receivers_remove_spaces_from_names() -> None:
    assert decode_request(b"\xffFC00RS.JOB      ") == FileExists(1, RS_JOB)
    assert decode_request(b"\xffFD00*           ") == ListFiles(1, "*")


# -- class attributes ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("cls", "shape", "changes_state", "dummy"),
    [
        (DownloadFile, Shape.MULTI, False, True),
        (UploadFile, Shape.UPLOAD, True, True),
        (FileExists, Shape.SINGLE, False, False),
        (ListFiles, Shape.MULTI, False, True),
        (DeleteFile, Shape.SINGLE, True, True),
        (CopyFile, Shape.SINGLE, True, True),
        (RenameFile, Shape.SINGLE, True, True),
        (ReadAlarmHistory, Shape.MULTI, False, True),
    ],
)
def test_class_attributes(
    cls: type[Command[Any]], shape: Shape, changes_state: bool, dummy: bool
) -> None:
    assert cls.SHAPE is shape
    assert_class_attributes(cls, changes_state=changes_state, dummy=dummy)


# -- FA --------------------------------------------------------------------------------------

JOB_ANSWER = [
    b"\xff0" + b"0003",
    b"\xff0" + b"MAIN\n",
    # The manual's content example: "IF I100==0 THEN" and its newline.
    b"\xff0" + b"IF I100==0 THEN\n",
    b"\xff0" + b"EOP\n",
    b"\xff4",
]
JOB = JobFile(("MAIN", "IF I100==0 THEN", "EOP"))

# "P0008", 6 axes x 11 bytes, ARM, USED, newline (the manual's PNT layout).
P8_LINE = (
    b"P0008"
    + b"    100.000"
    + b"    -20.500"
    + b"      0.000"
    + b"     90.000"
    + b"      0.000"
    + b"      0.000"
    + b"1"
    + b"1"
)
P8 = Point((100.0, -20.5, 0.0, 90.0, 0.0, 0.0), ArmForm.RIGHT, True)
P2_LINE = b"P0002" + b"      1.250" * 4 + b"2" + b"0"
P2 = Point((1.25,) * 4, ArmForm.NONE, False)
PNT_ANSWER = [b"\xff0" + b"0008", b"\xff0" + P2_LINE + b"\n", b"\xff0" + P8_LINE + b"\n", b"\xff4"]
PNT = PointFile({2: P2, 8: P8})


def test_fa_job_answer_both_ways() -> None:
    command = DownloadFile(1, RS_JOB)
    assert command.decode_answer(JOB_ANSWER) == JOB
    assert command.encode_answer(JOB) == JOB_ANSWER
    assert encode_packet(JOB_ANSWER[1]) == b"\x02\xff0MAIN\n\x03\xce"
    assert encode_packet(JOB_ANSWER[-1]) == b"\x02\xff4\x03\xcb"


def test_fa_max_step_is_read_at_any_width() -> None:
    # The manual's example announces "2000"; the width is not fixed.
    command = DownloadFile(1, RS_JOB)
    lines = [b"\xff0" + b"STEP %d\n" % i for i in range(2000)]
    assert command.decode_answer([b"\xff0" + b"2000", *lines, b"\xff4"]) == JobFile(
        tuple(f"STEP {i}" for i in range(2000))
    )
    for first in (b"3", b"  3", b"03"):
        assert command.decode_answer([b"\xff0" + first, *JOB_ANSWER[1:]]) == JOB


def test_fa_pnt_answer_both_ways() -> None:
    command = DownloadFile(1, RS_PNT)
    assert command.decode_answer(PNT_ANSWER) == PNT
    assert command.encode_answer(PNT) == PNT_ANSWER
    assert PNT.max_point == 8


def test_fa_empty_files() -> None:
    assert DownloadFile(1, RS_JOB).decode_answer([b"\xff0" + b"0000", b"\xff4"]) == JobFile(())
    assert DownloadFile(1, RS_PNT).decode_answer([b"\xff0" + b"0000", b"\xff4"]) == PointFile({})
    assert DownloadFile(1, RS_PNT).encode_answer(PointFile({})) == [b"\xff0" + b"0000", b"\xff4"]


@pytest.mark.parametrize(
    "packets",
    [
        [JOB_ANSWER[0], JOB_ANSWER[1], JOB_ANSWER[2], JOB_ANSWER[2], JOB_ANSWER[3], JOB_ANSWER[4]],
        [b"\xff4"],  # no size packet
        JOB_ANSWER[:-1],  # not closed by 0x34
    ],
)
def test_fa_job_integrity_errors(packets: list[bytes]) -> None:
    with pytest.raises(MalformedAnswerError):
        DownloadFile(1, RS_JOB).decode_answer(packets)


def test_fa_pnt_point_sent_twice_is_an_error() -> None:
    packets = [PNT_ANSWER[0], PNT_ANSWER[1], PNT_ANSWER[1], PNT_ANSWER[2], PNT_ANSWER[3]]
    with pytest.raises(MalformedAnswerError, match="twice"):
        DownloadFile(1, RS_PNT).decode_answer(packets)


# MAX STEP / MAX Point is a count on some controllers and the capacity on others (the manual's
# own example announces "2000" before a short job, issue #19): END ends the file, the figure is
# kept and never failed on.
@pytest.mark.parametrize("announced", [b"0003", b"2000", b"9999", b" 200", b"+003"])
def test_fa_job_max_step_may_be_the_count_or_the_capacity(announced: bytes) -> None:
    packets = [b"\xff0" + announced, *JOB_ANSWER[1:]]
    result = DownloadFile(1, RS_JOB).decode_answer(packets)
    assert result == JOB
    assert isinstance(result, JobFile) and result.announced == int(announced)


@pytest.mark.parametrize(
    "packets",
    [
        [b"\xff0" + b"0005", *PNT_ANSWER[1:]],  # a point above the figure
        [PNT_ANSWER[0], PNT_ANSWER[1], PNT_ANSWER[3]],  # the announced point not sent
        [b"\xff0" + b"2000", *PNT_ANSWER[1:]],  # the capacity
    ],
)
def test_fa_pnt_max_point_is_kept_not_checked(packets: list[bytes]) -> None:
    result = DownloadFile(1, RS_PNT).decode_answer(packets)
    assert isinstance(result, PointFile)
    assert result.announced == int(packets[0][2:])
    assert set(result.points) <= set(PNT.points)


def test_fa_result_must_match_the_file_kind() -> None:
    with pytest.raises(FieldError) as exc:
        DownloadFile(1, RS_JOB).encode_answer(PNT)
    assert exc.value.field == "result"
    with pytest.raises(FieldError) as exc:
        DownloadFile(1, RS_PNT).encode_answer(JOB)
    assert exc.value.field == "result"


def test_fa_long_lines_and_line_breaks_are_refused() -> None:
    command = DownloadFile(1, RS_JOB)
    assert len(command.encode_answer(JobFile(("x" * 99,)))[1]) == 2 + 100
    with pytest.raises(FieldError) as exc:
        command.encode_answer(JobFile(("MAIN", "x" * 100)))
    assert exc.value.field == "line 2"
    with pytest.raises(FieldError) as exc:
        command.encode_answer(JobFile(("MAIN\nEOP",)))
    assert exc.value.field == "line 1"


def test_point_line_helpers() -> None:
    assert format_point_line(8, P8) == P8_LINE.decode()
    assert parse_point_line(P8_LINE.decode()) == (8, P8)
    assert parse_point_line(P8_LINE.decode() + "\n") == (8, P8)
    for bad in (
        "Q" + P8_LINE.decode()[1:],
        P8_LINE.decode()[:-1],
        "P0008",
        "P00x8" + P8_LINE.decode()[5:],
    ):
        with pytest.raises(FieldError):
            parse_point_line(bad)
    with pytest.raises(FieldError) as exc:
        format_point_line(10000, P8)
    assert exc.value.field == "point number"
    with pytest.raises(FieldError):
        format_point_line(1, Point((1.0,) * 7))
    with pytest.raises(FieldError):
        format_point_line(1, Point((1e9,)))


@given(st.integers(0, 9999), points)
def test_point_line_round_trip(number: int, point: Point) -> None:
    line = format_point_line(number, point)
    assert len(line) == 5 + 11 * len(point.axes) + 2
    assert parse_point_line(line) == (number, point)


@given(st.lists(job_lines, max_size=30).map(tuple))
def test_fa_job_answer_round_trip(lines: tuple[str, ...]) -> None:
    command = DownloadFile(2, "ab.job")
    assert command.decode_answer(command.encode_answer(JobFile(lines))) == JobFile(lines)


@given(st.dictionaries(st.integers(0, 9999), points, max_size=20))
def test_fa_pnt_answer_round_trip(table: dict[int, Point]) -> None:
    command = DownloadFile(3, "ab.pnt", CoordSystem.XY)
    assert command.decode_answer(command.encode_answer(PointFile(table))) == PointFile(table)


# -- FB --------------------------------------------------------------------------------------


def test_fb_upload_bodies_are_lines_with_newlines() -> None:
    command = UploadFile(1, RS_JOB, 1, ("MAIN", "IF I100==0 THEN", "EOP"))
    bodies = command.upload_bodies()
    assert bodies == [b"MAIN\n", b"IF I100==0 THEN\n", b"EOP\n"]
    # The manual's content packet: STX 0x30 "IF I100==0 THEN" '\n' ETX LRC (no dummy).
    assert encode_packet(b"0" + bodies[1]) == b"\x020IF I100==0 THEN\n\x03\x6a"
    assert [UploadFile.decode_line(body) for body in bodies] == list(command.lines)


def test_fb_answers_are_bare_ok_flags() -> None:
    command = UploadFile(1, RS_JOB, 1, ("MAIN", "EOP"))
    assert command.encode_answer(None) == [b"\xff0"]
    command.decode_answer([b"\xff0"])
    command.decode_answer([b"\xff0", b"\xff0", b"0"])
    with pytest.raises(MalformedAnswerError):
        command.decode_answer([])
    with pytest.raises(MalformedAnswerError):
        command.decode_answer([b"\xff4"])
    with pytest.raises(FieldError):
        command.decode_answer([b"\xff0" + b"x"])


def test_fb_request_excludes_the_lines() -> None:
    # The lines travel in the upload packets; the request decodes without them.
    command = UploadFile(1, RS_JOB, 7, ["MAIN", "EOP"])
    assert command.lines == ("MAIN", "EOP")
    assert decode_request(command.encode()) == UploadFile(1, RS_JOB, 7)


def test_fb_lines_are_checked_before_the_request_is_sent() -> None:
    assert len(UploadFile(1, RS_JOB, 1, ("x" * 99,)).upload_bodies()[0]) == 100
    for lines, field in [
        (("MAIN", "x" * 100), "line 2"),
        (("MAIN\n",), "line 1"),
        (("MA\x03IN",), "line 1"),
        (("MAIN", "é"), "line 2"),
    ]:
        with pytest.raises(FieldError) as exc:
            UploadFile(1, RS_JOB, 1, lines).encode()
        field_error(exc, "FB", field, 0x31)
    with pytest.raises(FieldError) as exc:
        UploadFile(1, RS_JOB, 1, "MAIN").encode()
    assert exc.value.field == "lines"


def test_fb_pnt_upload_takes_point_lines() -> None:
    # Decision: a .PNT upload carries FA's point lines, so a downloaded backup can be restored.
    lines = (format_point_line(2, P2), format_point_line(8, P8))
    assert UploadFile(1, RS_PNT, 0, lines).upload_bodies() == [P2_LINE + b"\n", P8_LINE + b"\n"]
    with pytest.raises(FieldError) as exc:
        UploadFile(1, RS_PNT, 0, (lines[0], "MAIN")).encode()
    assert exc.value.field.startswith("line 2")
    with pytest.raises(FieldError) as exc:
        UploadFile(1, RS_PNT, 0, (lines[1], lines[1])).encode()
    assert exc.value.field == "line 2"


def test_fb_decode_line_refuses_bad_bodies() -> None:
    assert UploadFile.decode_line(b"EOP") == "EOP"
    for body in (b"x" * 101, b"MA\x01IN\n", b"\xe9\n"):
        with pytest.raises(FieldError):
            UploadFile.decode_line(body)


@given(job_lines)
def test_fb_line_round_trip(line: str) -> None:
    (body,) = UploadFile(1, RS_JOB, 1, (line,)).upload_bodies()
    assert UploadFile.decode_line(body) == line


def test_fb_job_number_range() -> None:
    for bad in (-1, 201):
        with pytest.raises(FieldError) as exc:
            UploadFile(1, RS_JOB, bad).encode()
        field_error(exc, "FB", "job_number", 0x31)
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffFB00201      RS.JOB")
    field_error(exc, "FB", "job_number", 0x31)


# -- FC, FD ----------------------------------------------------------------------------------


def test_fc_answer_both_ways() -> None:
    command = FileExists(1, RS_JOB)
    assert command.decode_answer([b"0" + b"1"]) is True
    assert command.decode_answer([b"0" + b"0"]) is False
    assert command.encode_answer(True) == [b"01"]
    assert command.encode_answer(False) == [b"00"]
    assert encode_packet(command.encode_answer(True)[0]) == b"\x0201\x03\x01"
    with pytest.raises(FieldError):
        command.decode_answer([b"0" + b"2"])


# The manual's examples: JOB 1, "RS.JOB", 27 KB, 200 steps, DATA "       0".
FD_BODY = b"  1" + b"RS.JOB    " + b"   27" + b"   200" + b"       0"
FD_RECORD = FileRecord(1, "RS.JOB", 27, 200)


def test_fd_answer_both_ways() -> None:
    command = ListFiles(1)
    other = FileRecord(12, "ab.pnt", 3, 0)
    packets = [b"\xff0" + FD_BODY, b"\xff0" + b" 12ab.pnt        3     0       0", b"\xff4"]
    assert command.decode_answer(packets) == (FD_RECORD, other)
    assert command.encode_answer((FD_RECORD, other)) == packets
    assert command.decode_answer([b"\xff4"]) == ()
    zero_padded = b"001" + b"RS.JOB    " + b"00027" + b"000200" + b"00000000"
    assert command.decode_answer([b"\xff0" + zero_padded, b"\xff4"]) == (FD_RECORD,)


def test_fd_answer_of_the_wrong_size_is_refused() -> None:
    with pytest.raises(FieldError):
        ListFiles(1).decode_answer([b"\xff0" + FD_BODY[:-1], b"\xff4"])
    with pytest.raises(FieldError):
        ListFiles(1).decode_answer([b"\xff0" + FD_BODY + b"0", b"\xff4"])
    with pytest.raises(FieldError) as exc:
        ListFiles(1).encode_answer((FileRecord(1000, "RS.JOB", 1, 1),))
    assert exc.value.field == "JOB NUM"


@given(
    st.lists(
        st.builds(
            FileRecord,
            st.integers(0, 999),
            file_names().map(str),
            st.integers(0, 99999),
            st.integers(0, 999999),
        ),
        max_size=10,
    ).map(tuple)
)
def test_fd_answer_round_trip(records: tuple[FileRecord, ...]) -> None:
    command = ListFiles(2)
    assert command.decode_answer(command.encode_answer(records)) == records


def test_fd_pattern_is_a_wildcard_or_a_name() -> None:
    with pytest.raises(FieldError) as exc:
        ListFiles(1, "TOOLONG.JOB").encode()
    field_error(exc, "FD", "pattern", 0x32)
    with pytest.raises(FieldError) as exc:
        ListFiles(1, "*.JOB").encode()
    field_error(exc, "FD", "pattern", 0x32)
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffFD00   TOOLONG.JOB")
    field_error(exc, "FD", "pattern", 0x32)


# -- FE, FF, FG ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "command",
    [DeleteFile(1, RS_JOB), CopyFile(1, RS_JOB, 1, "TT.JOB"), RenameFile(1, RS_JOB, "T1.JOB")],
)
def test_bare_flag_answers(command: Command[None]) -> None:
    assert command.encode_answer(None) == [b"\xff0"]
    assert command.decode_answer([b"\xff0"]) is None
    assert command.decode_answer([b"0"]) is None
    with pytest.raises(FieldError):
        command.decode_answer([b"\xff0" + b"1"])


def test_fe_data_byte_is_zero() -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffFE00      RS.JOB1")
    field_error(exc, "FE", "DATA", 0x31)


def test_fg_needs_the_separator_space() -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffFG00      RS.JOBx      T1.JOB")
    field_error(exc, "FG", "file separator", 0x31)


def test_ff_second_channel_and_name_are_checked() -> None:
    with pytest.raises(FieldError) as exc:
        CopyFile(1, RS_JOB, 4, "TT.JOB").encode()
    field_error(exc, "FF", "to_channel", 0x31)
    with pytest.raises(FieldError) as exc:
        CopyFile(1, RS_JOB, 1, "TT.TXT").encode()
    field_error(exc, "FF", "to_file", 0x32)
    with pytest.raises(FieldError) as exc:
        RenameFile(1, RS_JOB, "Tt.JOB").encode()
    field_error(exc, "FG", "new_file", 0x32)


def test_cross_channel_copy_and_pnt_delete_are_left_to_the_controller() -> None:
    # Both are controller rules (0x32 and, for FF, a run-fail alarm); the requests are valid.
    assert decode_request(CopyFile(1, RS_JOB, 2, "TT.JOB").encode()) == CopyFile(
        1, RS_JOB, 2, "TT.JOB"
    )
    assert decode_request(DeleteFile(1, RS_PNT).encode()) == DeleteFile(1, RS_PNT)


# -- shared field errors ---------------------------------------------------------------------

NAMED = [
    lambda name: DownloadFile(1, name),
    lambda name: UploadFile(1, name, 1),
    lambda name: FileExists(1, name),
    lambda name: DeleteFile(1, name),
    lambda name: CopyFile(1, name, 1, "TT.JOB"),
    lambda name: RenameFile(1, name, "T1.JOB"),
]


@pytest.mark.parametrize("make", NAMED)
@pytest.mark.parametrize("name", ["ABCDEF.JOB", "Rs.JOB", "RS.TXT", "RS", ".JOB", "R-S.JOB"])
def test_bad_names_are_refused_with_0x32(make: Any, name: str) -> None:
    command = make(name)
    with pytest.raises(FieldError) as exc:
        command.encode()
    field_error(exc, command.CODE, "file", 0x32)
    # The same fault met by a controller in a request: the flag it answers.
    good = make("RS.JOB").encode()
    data = good.replace(b"      RS.JOB", name.rjust(12).encode(), 1)
    with pytest.raises(FieldError) as exc:
        decode_request(data)
    field_error(exc, command.CODE, "file", 0x32)


@pytest.mark.parametrize("make", NAMED)
def test_channel_and_storage_type_are_checked(make: Any) -> None:
    good = make("RS.JOB")
    code = good.CODE
    with pytest.raises(FieldError) as exc:
        replace(good, channel=0).encode()
    field_error(exc, code, "channel", 0x31)
    data = good.encode()
    with pytest.raises(FieldError) as exc:
        decode_request(data[:3] + b"3" + data[4:])
    field_error(exc, code, "channel", 0x31)
    # Any storage TYPE but '0' (backup RAM) is "not supported": 0x33.
    with pytest.raises(FieldError) as exc:
        decode_request(data[:4] + b"1" + data[5:])
    field_error(exc, code, "TYPE", 0x33)


def test_fd_and_fh_storage_type() -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffFD01           *")
    field_error(exc, "FD", "TYPE", 0x33)
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffFH1alarm_history.txt" + b" " * 13)
    field_error(exc, "FH", "TYPE", 0x33)


def test_fa_coords_are_checked() -> None:
    with pytest.raises(FieldError) as exc:
        DownloadFile(1, RS_PNT, 2).encode()  # type: ignore[arg-type]
    field_error(exc, "FA", "coords", 0x31)
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffFA00      RS.PNT2")
    field_error(exc, "FA", "coords", 0x31)


def test_wrong_argument_types_name_the_field() -> None:
    with pytest.raises(FieldError) as exc:
        FileExists(1, 5).encode()  # type: ignore[arg-type]
    assert exc.value.field == "file"
    with pytest.raises(FieldError) as exc:
        ListFiles(1, 5).encode()  # type: ignore[arg-type]
    assert exc.value.field == "pattern"


# -- FH --------------------------------------------------------------------------------------

FH_HEADER = b"\xff0" + b"NO.\tERROR TIME\tCH ERROR MSG\t(CODE) "
FH_BODY = b"0103\t[12D 04:05:06]\tCH1 - T/P Emergency ,pressed\t(1153) "
FH_RECORD = AlarmRecord(1, 3, 12, 4, 5, 6, 1, "T/P Emergency", "pressed", 1153)


def test_fh_answer_both_ways() -> None:
    command = ReadAlarmHistory()
    all_channels = AlarmRecord(10, 10, 0, 23, 59, 59, 9, "Run Fail", "", 7)
    body2 = b"1010\t[0D 23:59:59]\tCH9 - Run Fail ,\t(   7) "
    packets = [FH_HEADER, b"\xff0" + FH_BODY, b"\xff0" + body2, b"\xff4"]
    assert command.decode_answer(packets) == (FH_RECORD, all_channels)
    assert command.encode_answer((FH_RECORD, all_channels)) == packets
    assert command.decode_answer([FH_HEADER, b"\xff4"]) == ()


def test_fh_answer_needs_header_and_format() -> None:
    command = ReadAlarmHistory()
    with pytest.raises(MalformedAnswerError):
        command.decode_answer([b"\xff0" + FH_BODY, b"\xff4"])
    with pytest.raises(MalformedAnswerError):
        command.decode_answer([b"\xff4"])
    with pytest.raises(MalformedAnswerError):
        command.decode_answer([FH_HEADER, b"\xff0" + FH_BODY.replace(b"\t(", b" ("), b"\xff4"])


def test_fh_records_are_cut_to_76_bytes() -> None:
    record = AlarmRecord(1, 1, 99999, 1, 2, 3, 2, "T" * 50, "D" * 50, -999)
    body = ReadAlarmHistory().encode_record(record)
    assert len(body) == 76
    (decoded,) = ReadAlarmHistory().decode_answer([FH_HEADER, b"\xff0" + body, b"\xff4"])
    assert decoded.detail == ""
    assert decoded.text == "T" * len(decoded.text)
    assert 30 < len(decoded.text) < 50
    assert decoded.code == -999
    # The detail is cut first: a text that fits is kept whole.
    record = replace(record, text="T" * 10)
    body = ReadAlarmHistory().encode_record(record)
    (decoded,) = ReadAlarmHistory().decode_answer([FH_HEADER, b"\xff0" + body, b"\xff4"])
    assert (len(body), decoded.text, decoded.detail) == (76, "T" * 10, "D" * 27)


def test_fh_record_limits() -> None:
    command = ReadAlarmHistory()
    changes: list[tuple[dict[str, Any], str]] = [
        ({"channel": 4}, "channel"),
        ({"hours": 24}, "hours"),
        ({"page": 100}, "page"),
        ({"code": 10000}, "alarm code"),
        ({"text": "A ,B"}, "text"),
        ({"text": "A\tB"}, "text"),
        ({"detail": "é"}, "detail"),
    ]
    for change, field in changes:
        record = replace(FH_RECORD, **change)
        with pytest.raises(FieldError) as exc:
            command.encode_answer((record,))
        assert exc.value.field == field


def test_fh_file_name_must_be_the_alarm_history() -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffFH0" + b"alarm.txt".ljust(30))
    field_error(exc, "FH", "file name", 0x32)


records = st.builds(
    AlarmRecord,
    st.integers(0, 99),
    st.integers(0, 99),
    st.integers(0, 99999),
    st.integers(0, 23),
    st.integers(0, 59),
    st.integers(0, 59),
    st.sampled_from([1, 2, 3, 9]),
    st.text(alphabet=printable, max_size=40).filter(lambda t: " ," not in t),
    st.text(alphabet=printable, max_size=40),
    st.integers(-999, 9999),
)


@given(st.lists(records, max_size=10).map(tuple))
def test_fh_answer_round_trip(history: tuple[AlarmRecord, ...]) -> None:
    command = ReadAlarmHistory()
    packets = command.encode_answer(history)
    assert all(len(packet) <= 2 + 76 for packet in packets)
    decoded = command.decode_answer(packets)
    assert len(decoded) == len(history)
    for packet, got, sent in zip(packets[1:], decoded, history, strict=False):
        assert sent.text.startswith(got.text)
        assert sent.detail.startswith(got.detail)
        assert (got.page, got.index, got.day, got.channel, got.code) == (
            sent.page,
            sent.index,
            sent.day,
            sent.channel,
            sent.code,
        )
        if (got.text, got.detail) != (sent.text, sent.detail):
            assert len(packet) == 2 + 76
        else:
            assert got == sent


# -- request round trips ---------------------------------------------------------------------

any_file_command = st.one_of(
    st.builds(DownloadFile, channels, file_names(), st.sampled_from(CoordSystem)),
    st.builds(UploadFile, channels, file_names(), st.integers(0, 200)),
    st.builds(FileExists, channels, file_names()),
    st.builds(ListFiles, channels, st.sampled_from(["*", "*.*"]) | file_names().map(str)),
    st.builds(DeleteFile, channels, file_names()),
    st.builds(CopyFile, channels, file_names(), channels, file_names()),
    st.builds(RenameFile, channels, file_names(), file_names()),
    st.just(ReadAlarmHistory()),
)


@given(any_file_command)
def test_request_round_trip(command: Command[Any]) -> None:
    assert_round_trip(command)
