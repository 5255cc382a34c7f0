"""Group F, files: FA-FH (download, upload, exists, list, delete, copy, rename, alarm history).

Every F request names the storage TYPE, and an N1 has only one (``'0'``, backup RAM); any other
value is answered 0x33. File names follow :class:`~robostar.protocol.fields.FileName`: a name
over 5 characters, a mixed-case name or an extension other than JOB/PNT is answered 0x32 by the
F commands. ``file`` fields take a FileName or a str (kept as a FileName).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Self

from robostar.commands.base import (
    FILE_NAME_WIDTH,
    Command,
    NoData,
    NumberField,
    Shape,
    encode_axes,
    file_arg,
    read_axes,
    set_fields,
)
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import (
    FLAG_FAILED,
    FLAG_UNSUPPORTED,
    FileName,
    Reader,
    check_range,
    encode_channel,
    encode_code,
    encode_int,
    encode_text,
    parse_int,
)
from robostar.types import AlarmRecord, ArmForm, CoordSystem, FileRecord, JobFile, Point, PointFile

__all__ = [
    "CopyFile",
    "DeleteFile",
    "DownloadFile",
    "FileExists",
    "ListFiles",
    "ReadAlarmHistory",
    "RenameFile",
    "UploadFile",
    "format_point_line",
    "parse_point_line",
]

STORAGE = b"0"
"""TYPE: backup RAM, the only storage an N1 has."""
LINE_MAX = 100
"""Bytes of one file-content field, its newline included (the manual's tables count it)."""
POINT_AXIS_WIDTH = 11
MAX_POINT_NUMBER = 9999
JOB_NUMBER = NumberField("job_number", 3, 0, 200)
WILDCARDS = ("*", "*.*")
ALARM_FILE = "alarm_history.txt"
ALARM_FILE_WIDTH = 30
ALARM_HEADER = "NO.\tERROR TIME\tCH ERROR MSG\t(CODE) "
ALARM_RECORD_MAX = 76
ALARM_CHANNELS = (1, 2, 3, 9)
ALARM_PAGES = 10
ALARM_RECORDS_PER_PAGE = 10
"""FH: the manual sends "ERR Page1-1" to "ERR Page10-10", at most ten records a page."""


# -- shared field helpers ------------------------------------------------------------------
def _as_name(command: str, field: str, value: object) -> FileName:
    """A FileName from a FileName or str argument, checked against the manual's name rules."""
    if isinstance(value, str):
        value = FileName.exact(value, command, field)
    if not isinstance(value, FileName):
        raise FieldError(command, field, f"must be a FileName or str, not {type(value).__name__}")
    return value.check(command, field)


def _read_storage(reader: Reader) -> None:
    reader.code("TYPE", 0, 0, flag=FLAG_UNSUPPORTED)


def _read_name(reader: Reader, field: str = "file") -> FileName:
    return reader.name(FILE_NAME_WIDTH, field).check(reader.command, field)


def _file_head(command: str, channel: int, name: FileName) -> bytes:
    """Channel, TYPE and a checked ``file``: how FA, FC and FE-FG requests start."""
    return encode_channel(command, channel) + STORAGE + name.encode(command, "file")


def _read_file_head(reader: Reader) -> tuple[int, FileName]:
    """Read what :func:`_file_head` writes: the channel and the file name."""
    channel = reader.channel()
    _read_storage(reader)
    return channel, _read_name(reader)


def _line_bodies(command: str, lines: object) -> list[bytes]:
    """File lines as content bodies (text + newline), each checked against the 100-byte limit."""
    if isinstance(lines, str) or not isinstance(lines, Sequence):
        raise FieldError(command, "lines", "must be a sequence of strings, one per line")
    bodies = []
    for number, line in enumerate(lines, 1):
        field = f"line {number}"
        if not isinstance(line, str):
            raise FieldError(command, field, f"must be a str, not {type(line).__name__}")
        if "\n" in line or "\r" in line:
            raise FieldError(command, field, "holds a line break")
        body = encode_text(command, field, line, len(line)) + b"\n"
        if len(body) > LINE_MAX:
            raise FieldError(
                command, field, f"is {len(body)} bytes with its newline; at most {LINE_MAX}"
            )
        bodies.append(body)
    return bodies


def _line_text(body: bytes) -> str:
    return (body[:-1] if body.endswith(b"\n") else body).decode("ascii", "replace")


# -- PNT lines -------------------------------------------------------------------------------
def format_point_line(number: int, point: Point, *, command: str = "FA") -> str:
    """One PNT point as FA sends it and FB takes it, without its newline.

    ``"P0008"`` then 11 bytes per axis (right-aligned, 3 decimals), then ARM and USED digits.
    """
    check_range(command, "point number", number, 0, MAX_POINT_NUMBER)
    if not isinstance(point, Point):
        raise FieldError(command, "point", f"must be a Point, not {type(point).__name__}")
    check_range(command, f"point {number} axis count", len(point.axes), 1, 6)
    axes = encode_axes(command, point.axes, f"point {number}", POINT_AXIS_WIDTH)
    arm = check_range(command, f"point {number} ARM", point.arm, 0, 2)
    used = "1" if point.used else "0"
    return f"P{number:04d}{axes.decode('ascii')}{arm:d}{used}"


def parse_point_line(
    text: str, *, command: str = "FA", field: str = "point line"
) -> tuple[int, Point]:
    """Read a line written by :func:`format_point_line` (a trailing newline is allowed)."""
    raw = text.removesuffix("\n").encode("ascii", "replace")
    count, extra = divmod(len(raw) - 7, POINT_AXIS_WIDTH)
    if raw[:1] != b"P" or extra or not 1 <= count <= 6:
        raise FieldError(command, field, f"{text!r} is not 'P' + 4 digits + 11 x axes + ARM USED")
    r = Reader(command, raw, 1)
    number = r.number(4, f"{field} number", lo=0, hi=MAX_POINT_NUMBER)
    axes = read_axes(r, count, field, POINT_AXIS_WIDTH)
    arm = r.enum(f"{field} ARM", ArmForm)
    used = r.code(f"{field} USED", 0, 1)
    return number, Point(axes, arm, bool(used))


# -- FA --------------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True, init=False)
class DownloadFile(Command[JobFile | PointFile]):
    """FA: download a JOB or PNT file from the controller, one step or point per packet.

    The first packet announces the max step (JOB) or the max point (PNT): a count on some
    controllers, the capacity on others. The END packet ends the file; the figure is kept on the
    result (``announced``) and never failed on, except that a JOB may not be longer than
    announced (a packet was duplicated) and a PNT file may not hold a point twice.
    ``coords`` (PNT_TYPE) picks angle or XY data for a PNT file.
    """

    CODE = "FA"
    SHAPE = Shape.MULTI
    ANSWER_DUMMY = True
    MAX_PACKETS = 9999 + 2  # the announcement, up to 9999 steps or points, END
    channel: int
    file: FileName
    coords: CoordSystem

    def __init__(
        self, channel: int, file: FileName | str, coords: CoordSystem = CoordSystem.ANGLE
    ) -> None:
        set_fields(self, channel=channel, file=file_arg(file), coords=coords)

    def encode_params(self) -> bytes:
        name = _as_name(self.CODE, "file", self.file)
        coords = encode_code(self.CODE, "coords", self.coords, 0, 1)
        return _file_head(self.CODE, self.channel, name) + coords

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel, name = _read_file_head(reader)
        return cls(channel, name, reader.enum("coords", CoordSystem))

    def _is_job(self) -> bool:
        return self.file.is_job

    def decode_answer(self, packets: Sequence[bytes]) -> JobFile | PointFile:
        bodies = self.multi_bodies(packets)
        if not bodies:
            raise MalformedAnswerError(self.CODE, "no packet announcing the file's size")
        announced = parse_int(self.CODE, "max number", bodies[0])
        # The first packet is the controller's MAX STEP / MAX Point: a count on some
        # controllers, the capacity on others (the manual's example announces 2000 before a
        # short job). The END packet ends the file; the figure is kept, never held against it.
        if self._is_job():
            lines = tuple(_line_text(body) for body in bodies[1:])
            if announced < len(lines):
                # Neither a count nor a capacity can be below the steps sent.
                raise MalformedAnswerError(
                    self.CODE,
                    f"announced at most {announced} steps but sent {len(lines)}: "
                    "a packet was duplicated",
                )
            return JobFile(lines, announced=announced)
        points: dict[int, Point] = {}
        for body in bodies[1:]:
            number, point = parse_point_line(body.decode("ascii", "replace"), command=self.CODE)
            if number in points:
                raise MalformedAnswerError(self.CODE, f"point {number} sent twice", body)
            points[number] = point
        return PointFile(points, announced=announced)

    def encode_answer(self, result: JobFile | PointFile) -> list[bytes]:
        if self._is_job():
            if not isinstance(result, JobFile):
                raise FieldError(self.CODE, "result", "a .JOB file downloads as a JobFile")
            first = encode_int(self.CODE, "max step", len(result.lines), 4, lo=0, hi=9999)
            bodies = _line_bodies(self.CODE, result.lines)
        else:
            if not isinstance(result, PointFile):
                raise FieldError(self.CODE, "result", "a .PNT file downloads as a PointFile")
            first = encode_int(
                self.CODE, "max point", result.max_point, 4, lo=0, hi=MAX_POINT_NUMBER
            )
            bodies = [
                format_point_line(number, result.points[number], command=self.CODE).encode() + b"\n"
                for number in sorted(result.points)
            ]
        return [self.ok(first), *(self.ok(body) for body in bodies), self.end()]


# -- FB --------------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True, init=False)
class UploadFile(Command[None]):
    """FB: upload a file to the controller, one line per packet (the roles turn, see Shape).

    The request carries the channel, the JOB number (0-200) and the name; ``lines`` follow as
    ``0x30`` content packets (:meth:`upload_bodies`), each answered ``FF 0x30``, and the host
    closes with ``0x34``. The lines are the file's steps, ``MAIN`` to ``EOP``, without the max
    step (the manual's caution). Each content field is at most 100 bytes, newline included.

    Decision: a .PNT name may be uploaded too, its lines in FA's point-line format
    (:func:`format_point_line`, angle data), so that a downloaded backup can be restored; the
    manual shows JOB files only. Lines are checked before the request is sent.
    """

    CODE = "FB"
    SHAPE = Shape.UPLOAD
    CHANGES_STATE = True
    ANSWER_DUMMY = True
    channel: int
    file: FileName
    job_number: int
    lines: tuple[str, ...]

    def __init__(
        self, channel: int, file: FileName | str, job_number: int, lines: Sequence[str] = ()
    ) -> None:
        if isinstance(lines, Sequence) and not isinstance(lines, str):
            lines = tuple(lines)
        set_fields(self, channel=channel, file=file_arg(file), job_number=job_number, lines=lines)

    def encode_params(self) -> bytes:
        name = _as_name(self.CODE, "file", self.file)
        self.upload_bodies()
        return (
            encode_channel(self.CODE, self.channel)
            + STORAGE
            + JOB_NUMBER.encode(self.CODE, self.job_number)
            + name.encode(self.CODE, "file")
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        _read_storage(reader)
        job_number = JOB_NUMBER.read(reader)
        return cls(channel, _read_name(reader), job_number)

    def upload_bodies(self) -> list[bytes]:
        """The content packets' bodies (after the 0x30 flag): each line and its newline."""
        bodies = _line_bodies(self.CODE, self.lines)
        name = _as_name(self.CODE, "file", self.file)
        if name.is_points:
            seen: set[int] = set()
            for number, line in enumerate(self.lines, 1):
                point_number, _ = parse_point_line(line, command=self.CODE, field=f"line {number}")
                if point_number in seen:
                    raise FieldError(
                        self.CODE, f"line {number}", f"point P{point_number:04d} is repeated"
                    )
                seen.add(point_number)
        return bodies

    @staticmethod
    def decode_line(body: bytes) -> str:
        """A content packet's body as its line (controller side); FieldError if it breaks the
        100-byte limit or holds control bytes."""
        if len(body) > LINE_MAX:
            raise FieldError("FB", "line", f"{len(body)} bytes is over {LINE_MAX}")
        text = body.removesuffix(b"\n")
        if any(byte < 0x20 and byte != 0x09 for byte in text) or not text.isascii():
            raise FieldError("FB", "line", f"{text!r} holds control or non-ASCII bytes")
        return text.decode("ascii")

    def decode_answer(self, packets: Sequence[bytes]) -> None:
        # The controller's replies (to the request and to each line) are all a bare FF 0x30.
        if not packets:
            raise MalformedAnswerError(self.CODE, "no reply")
        self.bare_flags(packets)

    def encode_answer(self, result: None) -> list[bytes]:
        return [self.ok()]


# -- FC --------------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True, init=False)
class FileExists(Command[bool]):
    """FC: does the channel hold this file? The answer is '0' (no) or '1' (yes)."""

    CODE = "FC"
    channel: int
    file: FileName

    def __init__(self, channel: int, file: FileName | str) -> None:
        set_fields(self, channel=channel, file=file_arg(file))

    def encode_params(self) -> bytes:
        name = _as_name(self.CODE, "file", self.file)
        return _file_head(self.CODE, self.channel, name)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        return cls(*_read_file_head(reader))

    def decode_answer(self, packets: Sequence[bytes]) -> bool:
        r = self.single(packets)
        exists = r.code("DATA", 0, 1)
        r.end()
        return bool(exists)

    def encode_answer(self, result: bool) -> list[bytes]:
        return [self.ok(b"1" if result else b"0")]


# -- FD --------------------------------------------------------------------------------------
FD_RESERVED = b"       0"
"""FD's DATA field: "planned", always 0 in 8 bytes."""


@dataclass(frozen=True, slots=True, init=False)
class ListFiles(Command[tuple[FileRecord, ...]]):
    """FD: describe one file, or every JOB and PNT file of a channel (``*`` or ``*.*``).

    One packet per file: JOB number (3), name (10, left-aligned), size in KB (5), step count
    (6), and a reserved 8-byte field that is always ``0``.
    """

    CODE = "FD"
    SHAPE = Shape.MULTI
    ANSWER_DUMMY = True
    MAX_PACKETS = 2 * (JOB_NUMBER.hi + 1) + 1
    DISTINCT_PACKETS = True  # one packet per file
    """``*`` lists a channel's JOB files and their PNT files: JOB numbers run 0-200 (FB), so at
    most 201 of each, and END (403 packets)."""
    channel: int
    pattern: str

    def __init__(self, channel: int, pattern: str | FileName = "*") -> None:
        # Kept as the text a controller reads back: a FileName's text, spaces removed.
        if isinstance(pattern, FileName):
            pattern = str(pattern)
        elif isinstance(pattern, str):
            pattern = pattern.replace(" ", "")
        object.__setattr__(self, "channel", channel)
        object.__setattr__(self, "pattern", pattern)

    def encode_params(self) -> bytes:
        if self.pattern in WILDCARDS:
            name = encode_text(self.CODE, "pattern", self.pattern, FILE_NAME_WIDTH, align=">")
        else:
            name = _as_name(self.CODE, "pattern", self.pattern).encode(self.CODE, "pattern")
        return encode_channel(self.CODE, self.channel) + STORAGE + name

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel = reader.channel()
        _read_storage(reader)
        name = reader.name(FILE_NAME_WIDTH, "pattern")
        if str(name) not in WILDCARDS:
            name.check(cls.CODE, "pattern")
        return cls(channel, str(name))

    def decode_answer(self, packets: Sequence[bytes]) -> tuple[FileRecord, ...]:
        records = []
        for body in self.multi_bodies(packets):
            r = Reader(self.CODE, body)
            job_number = r.number(3, "JOB NUM")
            name = r.text(10, "file name")
            size = r.number(5, "SIZE")
            steps = r.number(6, "STEP")
            r.number(8, "DATA")
            r.end()
            records.append(FileRecord(job_number, name, size, steps))
        return tuple(records)

    def encode_answer(self, result: tuple[FileRecord, ...]) -> list[bytes]:
        packets = []
        for record in result:
            body = (
                encode_int(self.CODE, "JOB NUM", record.job_number, 3, lo=0, hi=999, pad=" ")
                + encode_text(self.CODE, "file name", record.name, 10)
                + encode_int(self.CODE, "SIZE", record.size_kb, 5, lo=0, hi=99999, pad=" ")
                + encode_int(self.CODE, "STEP", record.steps, 6, lo=0, hi=999999, pad=" ")
                + FD_RESERVED
            )
            packets.append(self.ok(body))
        return [*packets, self.end()]


# -- FE, FF, FG ------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True, init=False)
class DeleteFile(NoData):
    """FE: delete a file. The request's trailing DATA byte is reserved and always '0'.

    The manual says only JOB files can be deleted yet (a PNT name is answered 0x32); that is a
    controller rule, left to the controller, so the request itself may name a PNT file.
    """

    CODE = "FE"
    CHANGES_STATE = True
    ANSWER_DUMMY = True
    channel: int
    file: FileName

    def __init__(self, channel: int, file: FileName | str) -> None:
        set_fields(self, channel=channel, file=file_arg(file))

    def encode_params(self) -> bytes:
        name = _as_name(self.CODE, "file", self.file)
        return _file_head(self.CODE, self.channel, name) + b"0"

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel, name = _read_file_head(reader)
        reader.code("DATA", 0, 0)
        return cls(channel, name)


@dataclass(frozen=True, slots=True, init=False)
class CopyFile(NoData):
    """FF: copy a file to a new name.

    The manual allows copies within one channel only (across channels: run-fail alarm and
    0x32); that is a controller rule, so the request may still name two channels.
    """

    CODE = "FF"
    CHANGES_STATE = True
    ANSWER_DUMMY = True
    channel: int
    file: FileName
    to_channel: int
    to_file: FileName

    def __init__(
        self, channel: int, file: FileName | str, to_channel: int, to_file: FileName | str
    ) -> None:
        set_fields(
            self,
            channel=channel,
            file=file_arg(file),
            to_channel=to_channel,
            to_file=file_arg(to_file),
        )

    def encode_params(self) -> bytes:
        source = _as_name(self.CODE, "file", self.file)
        target = _as_name(self.CODE, "to_file", self.to_file)
        return (
            _file_head(self.CODE, self.channel, source)
            + encode_channel(self.CODE, self.to_channel, "to_channel")
            + target.encode(self.CODE, "to_file")
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel, source = _read_file_head(reader)
        to_channel = reader.channel("to_channel")
        return cls(channel, source, to_channel, _read_name(reader, "to_file"))


@dataclass(frozen=True, slots=True, init=False)
class RenameFile(NoData):
    """FG: rename a file. The first name takes 13 bytes: the 12-byte name, then a space that
    the manual calls a separator (without it the request is invalid)."""

    CODE = "FG"
    CHANGES_STATE = True
    ANSWER_DUMMY = True
    channel: int
    file: FileName
    new_file: FileName

    def __init__(self, channel: int, file: FileName | str, new_file: FileName | str) -> None:
        set_fields(self, channel=channel, file=file_arg(file), new_file=file_arg(new_file))

    def encode_params(self) -> bytes:
        old = _as_name(self.CODE, "file", self.file)
        new = _as_name(self.CODE, "new_file", self.new_file)
        return _file_head(self.CODE, self.channel, old) + b" " + new.encode(self.CODE, "new_file")

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel, old = _read_file_head(reader)
        if reader.take(1, "file separator") != b" ":
            raise FieldError(cls.CODE, "file separator", "the 13th byte must be a space")
        return cls(channel, old, _read_name(reader, "new_file"))


# -- FH --------------------------------------------------------------------------------------
_RECORD = re.compile(
    r"(\d{2})(\d{2})\t\[(\d+)D (\d{2}):(\d{2}):(\d{2})\]\tCH(\d) - (.*?) ,(.*)\t\(\s*(-?\d+)\) ?"
)


def _record_text(record: AlarmRecord, text: str, detail: str) -> str:
    return (
        f"{record.page:02d}{record.index:02d}\t[{record.day:d}D {record.hours:02d}:"
        f"{record.minutes:02d}:{record.seconds:02d}]\tCH{record.channel:d} - {text} ,{detail}"
        f"\t({record.code:4d}) "
    )


def _check_record_text(command: str, field: str, value: object) -> str:
    if not isinstance(value, str):
        raise FieldError(command, field, f"must be a str, not {type(value).__name__}")
    if not value.isascii() or any(ord(c) < 0x20 for c in value):
        raise FieldError(command, field, f"{value!r} must be ASCII without control characters")
    return value


@dataclass(frozen=True, slots=True)
class ReadAlarmHistory(Command[tuple[AlarmRecord, ...]]):
    """FH: read the stored alarm history (the file ``alarm_history.txt``, up to 10 pages of 10).

    The first answer packet is a header line; then one record per packet, at most 76 bytes::

        "%02d%02d\\t[%dD %02d:%02d:%02d]\\tCH%d - %s ,%s\\t(%4d) "

    page and index first, then the work timer (day, h, m, s), the channel (1-3, or 9 for all),
    the alarm text, the detail and the code. The manual prints the tab as ``Wt`` (a backslash
    shown as the Won sign) and its table puts page and index (two ``%02d``) in front. Text and
    detail are cut to fit the 76 bytes, detail first; the text may not hold ``" ,"`` (the
    separator). A request naming any other file is answered 0x32 (no such file).
    """

    CODE = "FH"
    SHAPE = Shape.MULTI
    ANSWER_DUMMY = True
    MAX_PACKETS = 1 + ALARM_PAGES * ALARM_RECORDS_PER_PAGE + 1
    DISTINCT_PACKETS = True  # each record carries its page and index
    """The header, ten pages of ten records, END (102 packets)."""

    def encode_params(self) -> bytes:
        return STORAGE + encode_text(self.CODE, "file name", ALARM_FILE, ALARM_FILE_WIDTH)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        _read_storage(reader)
        name = reader.text(ALARM_FILE_WIDTH, "file name")
        if name != ALARM_FILE:
            raise FieldError(
                cls.CODE, "file name", f"{name!r} is not {ALARM_FILE!r}", flag=FLAG_FAILED
            )
        return cls()

    def decode_answer(self, packets: Sequence[bytes]) -> tuple[AlarmRecord, ...]:
        bodies = self.multi_bodies(packets)
        if not bodies or not bodies[0].startswith(b"NO."):
            raise MalformedAnswerError(self.CODE, "the header packet is missing")
        records = []
        for body in bodies[1:]:
            match = _RECORD.fullmatch(body.decode("ascii", "replace"))
            if match is None:
                raise MalformedAnswerError(self.CODE, "not an alarm record", body)
            page, index, day, hours, minutes, seconds, channel = map(int, match.group(*range(1, 8)))
            text, detail, code = match.group(8, 9, 10)
            records.append(
                AlarmRecord(
                    page, index, day, hours, minutes, seconds, channel, text, detail, int(code)
                )
            )
        return tuple(records)

    def encode_record(self, record: AlarmRecord) -> bytes:
        """One record's body, text and detail cut (detail first) to fit 76 bytes."""
        code = self.CODE
        check_range(code, "page", record.page, 0, 99)
        check_range(code, "index", record.index, 0, 99)
        check_range(code, "day", record.day, 0, 99999)
        check_range(code, "hours", record.hours, 0, 23)
        check_range(code, "minutes", record.minutes, 0, 59)
        check_range(code, "seconds", record.seconds, 0, 59)
        check_range(code, "alarm code", record.code, -999, 9999)
        if record.channel not in ALARM_CHANNELS:
            raise FieldError(code, "channel", f"{record.channel} is not 1, 2, 3 or 9 (all)")
        text = _check_record_text(code, "text", record.text)
        detail = _check_record_text(code, "detail", record.detail)
        if " ," in text:
            raise FieldError(code, "text", f"{text!r} holds ' ,', the text/detail separator")
        spare = ALARM_RECORD_MAX - len(_record_text(record, "", ""))
        detail = detail[: max(spare - len(text), 0)]
        text = text[: spare - len(detail)]
        return _record_text(record, text, detail).encode("ascii")

    def encode_answer(self, result: tuple[AlarmRecord, ...]) -> list[bytes]:
        records = [self.ok(self.encode_record(record)) for record in result]
        return [self.ok(ALARM_HEADER.encode("ascii")), *records, self.end()]
