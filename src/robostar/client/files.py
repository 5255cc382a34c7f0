"""File transfer plans: names, JOB numbers, downloads and uploads (FA, FB, FD)."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

from robostar.client.exchange import Progress
from robostar.client.plan import Plan, call
from robostar.commands.files import DownloadFile, ListFiles, UploadFile, format_point_line
from robostar.errors import FieldError, MalformedAnswerError, UsageError
from robostar.protocol.fields import FileName
from robostar.types import CoordSystem, JobFile, Point, PointFile

__all__ = [
    "MAX_JOB_NUMBER",
    "NAME_RULE",
    "download_job",
    "download_points",
    "file_name",
    "job_number",
    "parse_name",
    "point_lines",
    "upload",
]

MAX_JOB_NUMBER = 200


NAME_RULE = (
    "a controller file name is 1-5 letters, digits or _ in one case, then .JOB or .PNT "
    "(no spaces, no control characters)"
)

_NAME_TEXT = re.compile(r"[A-Za-z0-9_]*(\.[A-Za-z0-9_]*)?")


def parse_name(text: str, name: str) -> FileName:
    """``text`` as a FileName, refusing what the wire would silently change: the protocol's
    parser drops spaces and NUL bytes (``"A B.JOB"`` would become ``AB.JOB``)."""
    if not _NAME_TEXT.fullmatch(text):
        raise UsageError(f"{name} {text!r}: {NAME_RULE}")
    return FileName.parse(text)


def file_name(value: object, name: str, kind: str | None = None) -> FileName:
    """A checked file name from a str or FileName; ``kind`` ("JOB"/"PNT") is added when the
    name has no extension, and required when it has one."""
    if isinstance(value, str):
        parsed = parse_name(value, name)
    elif isinstance(value, FileName):
        parsed = value
    else:
        raise UsageError(f"{name}: must be a file name like 'MAIN.JOB', not {value!r}")
    if kind is not None and not parsed.extension:
        parsed = FileName(parsed.stem, kind.lower() if parsed.stem.islower() else kind)
    return parsed.check("", name, kind=kind)


def point_lines(points: PointFile | Mapping[int, Point]) -> tuple[str, ...]:
    """A PNT file's points as FB content lines (FA's point-line format), by point number."""
    table = points.points if isinstance(points, PointFile) else points
    if not isinstance(table, Mapping):
        raise UsageError(
            f"points: must be a PointFile or a mapping of number to Point, not {points!r}"
        )
    return tuple(format_point_line(number, table[number], command="FB") for number in sorted(table))


def job_number(channel: int, file: FileName, number: int | None) -> Plan[int]:
    """The JOB number to upload ``file`` with.

    The controller requires a file's JOB number to stay the same (an upload under another
    number raises an alarm), so by default the number of an existing file of that name is
    kept; a new JOB file takes the lowest number no JOB file of the channel uses, and a new
    PNT file takes 0.
    """
    if number is not None:
        if isinstance(number, bool) or not isinstance(number, int):
            raise UsageError(f"number: must be a JOB number 0-{MAX_JOB_NUMBER}, not {number!r}")
        if not 0 <= number <= MAX_JOB_NUMBER:
            raise FieldError("", "number", f"{number} is out of range 0..{MAX_JOB_NUMBER}")
        return number
    records = yield from call(ListFiles(channel, "*"))
    for record in records:
        if FileName.parse(record.name).key == file.key:
            return record.job_number
    if file.is_points:
        return 0
    used = {r.job_number for r in records if FileName.parse(r.name).is_job}
    free = next((n for n in range(1, MAX_JOB_NUMBER + 1) if n not in used), None)
    if free is None:
        raise UsageError(
            f"number: every JOB number 1-{MAX_JOB_NUMBER} of channel {channel} is used"
        )
    return free


def download_job(channel: int, name: object, progress: Progress | None) -> Plan[JobFile]:
    file = file_name(name, "name", "JOB")
    content = yield from call(DownloadFile(channel, file), progress)
    if not isinstance(content, JobFile):
        raise UsageError(f"name: {file} is not a JOB file")
    for number, line in enumerate(content.lines, 1):
        if not line.isascii():
            # FA decodes bytes outside ASCII as U+FFFD: the file cannot be kept as it was.
            raise MalformedAnswerError(
                "FA", f"{file} line {number} holds bytes that are not ASCII: {line!r}"
            )
    return content


def download_points(
    channel: int, name: object, coords: CoordSystem, progress: Progress | None
) -> Plan[PointFile]:
    file = file_name(name, "name", "PNT")
    content = yield from call(DownloadFile(channel, file, coords), progress)
    if not isinstance(content, PointFile):
        raise UsageError(f"name: {file} is not a PNT file")
    return content


def upload(
    channel: int,
    file: FileName,
    lines: Sequence[str],
    number: int | None,
    progress: Progress | None,
) -> Plan[None]:
    """FB, verified (see :mod:`robostar.client.driver`); the lines are checked first."""
    if isinstance(lines, str) or not isinstance(lines, Sequence):
        raise UsageError("lines: must be a sequence of strings, one per step")
    # Encoding checks every line before FD (for the JOB number) or FB is sent.
    UploadFile(channel, file, 0, tuple(lines)).encode()
    chosen = yield from job_number(channel, file, number)
    yield from call(UploadFile(channel, file, chosen, tuple(lines)), progress)
