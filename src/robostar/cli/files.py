"""Files on the controller: ``files ls|get|put|rm|cp|mv``, ``backup DIR`` and ``restore DIR``.

On disk a JOB file is its steps, one per line (MAIN to EOP); a PNT file is FA's point lines
(``P0001`` then 11 bytes per axis, ARM and USED), so a downloaded file uploads unchanged.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click
from rich.console import Group, RenderableType
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from robostar.cli.control import done
from robostar.cli.options import common_options
from robostar.cli.render import jsonable
from robostar.cli.session import PlannedFrame, Session, pass_session
from robostar.client.files import parse_name
from robostar.commands import Command
from robostar.commands.files import (
    CopyFile,
    DeleteFile,
    DownloadFile,
    ListFiles,
    RenameFile,
    UploadFile,
    format_point_line,
    parse_point_line,
)
from robostar.errors import FieldError, UsageError
from robostar.protocol.fields import FileName
from robostar.protocol.frame import encode_packet
from robostar.types import CoordSystem, JobFile, Point, PointFile

__all__ = ["backup", "file_lines", "files", "read_local", "restore", "write_atomic"]


def _name(text: str, what: str = "name") -> FileName:
    name = parse_name(text, what)
    try:
        return name.check("", what)
    except FieldError as error:
        raise UsageError(f"{what} {text!r}: {error.message}") from None


def write_atomic(target: Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``target`` and rename it into place only when
    complete: an interrupted or failed write never leaves a partial or empty ``target``."""
    fd, temporary = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def file_lines(content: JobFile | PointFile) -> list[str]:
    """A downloaded file as the lines written to disk."""
    if isinstance(content, JobFile):
        return list(content.lines)
    return [format_point_line(n, content.points[n]) for n in sorted(content.points)]


def read_local(path: Path, name: FileName) -> list[str]:
    """A local file's lines for upload; a PNT file's lines are checked as point lines."""
    try:
        text = path.read_text(encoding="ascii")
    except UnicodeDecodeError:
        raise UsageError(f"{path} holds non-ASCII bytes; the controller takes ASCII only") from None
    except OSError as error:
        raise UsageError(f"cannot read {path}: {error.strerror or error}") from None
    lines = [line.rstrip("\r") for line in text.splitlines()]
    if name.is_points:
        lines = [line for line in lines if line.strip()]
        for number, line in enumerate(lines, 1):
            try:
                parse_point_line(line, command="FB", field=f"line {number}")
            except FieldError as error:
                raise UsageError(f"{path}: {error.field}: {error.message}") from None
    return lines


def _points(lines: list[str]) -> dict[int, Point]:
    return dict(parse_point_line(line, command="FB") for line in lines)


@contextmanager
def _progress(session: Session, label: str) -> Iterator[Callable[[int, int | None], None]]:
    """A progress bar on stderr (none in JSON mode), fed by the client's progress callback."""
    if session.out.json:
        yield lambda done, total: None
        return
    bar = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=session.out.err,
        transient=False,
    )
    task = bar.add_task(label, total=None)

    def update(count: int, total: int | None) -> None:
        bar.update(task, completed=count, total=total)

    with bar:
        yield update


@click.group()
def files() -> None:
    """JOB and PNT files on the controller: ls, get, put, rm, cp, mv.

    \b
    Example:
      robostar files ls
      robostar files get DEMO.JOB demo.job
    """


@files.command("ls")
@click.argument("pattern", default="*")
@common_options(channel=True)
@pass_session
def files_ls(session: Session, pattern: str) -> None:
    """List the channel's JOB and PNT files (FD): number, name, size, steps.

    \b
    Example:
      robostar files ls
      robostar --channel 2 files ls DEMO.JOB
    """
    records = session.send(ListFiles(session.channel, pattern))

    def view() -> RenderableType:
        if not records:
            return Text(f"No files on channel {session.channel}.")
        table = Table(title=f"Channel {session.channel} files", title_justify="left")
        for column in ("job no.", "name", "size (KB)", "steps"):
            table.add_column(column, justify="left" if column == "name" else "right")
        for r in records:
            table.add_row(str(r.job_number), r.name, str(r.size_kb), str(r.steps))
        return table

    session.out.result({"channel": session.channel, "files": jsonable(records)}, view)


@files.command("get")
@click.argument("name")
@click.argument("dest", required=False, type=click.Path(dir_okay=False, allow_dash=True))
@click.option("--xy", is_flag=True, help="A PNT file's points in XY rather than joint angles.")
@click.option("--force", is_flag=True, help="Overwrite DEST if it exists.")
@common_options(channel=True)
@pass_session
def files_get(session: Session, name: str, dest: str | None, xy: bool, force: bool) -> None:
    """Download file NAME (FA) to DEST (default: ./NAME; - for standard output).

    \b
    Example:
      robostar files get DEMO.JOB
      robostar files get DEMO.PNT - --xy
    """
    file = _name(name)
    coords = CoordSystem.XY if xy else CoordSystem.ANGLE
    target = Path(dest or str(file))
    if dest != "-" and target.exists() and not force:
        raise UsageError(f"{target} exists; give --force to overwrite it")
    command = DownloadFile(session.channel, file, coords)
    if session.dry_run:
        session.plan([command])
    with _progress(session, f"downloading {file}") as progress:
        if file.is_job:
            content: JobFile | PointFile = session.client.download_job(
                session.channel, file, progress=progress
            )
        else:
            content = session.client.download_points(
                session.channel, file, coords="xy" if xy else "angle", progress=progress
            )
    lines = file_lines(content)
    text = "".join(line + "\n" for line in lines)
    if dest == "-":
        if session.out.json:
            session.out.result({"name": str(file), "lines": lines})
        else:
            click.echo(text, nl=False)
        return
    try:
        write_atomic(target, text.encode("ascii"))
    except OSError as error:
        raise UsageError(f"dest: cannot write {str(target)!r}: {error}") from error
    done(
        session,
        f"Saved {file} ({len(lines)} lines) to {target}.",
        name=str(file),
        path=str(target),
        lines=len(lines),
    )


@files.command("put")
@click.argument("source", type=click.Path(exists=True, dir_okay=False))
@click.option(
    "--name", "name", default=None, help="The name on the controller (default: SOURCE's)."
)
@click.option(
    "--number",
    type=click.IntRange(0, 200),
    default=None,
    help="The JOB number (default: the file's own, or the first free one).",
)
@common_options(channel=True)
@pass_session
def files_put(session: Session, source: str, name: str | None, number: int | None) -> None:
    """Upload SOURCE (FB) as a JOB or PNT file; the upload is verified by reading it back.

    \b
    Example:
      robostar files put demo.job --name DEMO.JOB
      robostar files put ARC.PNT
    """
    path = Path(source)
    file = _name(name or path.name, "--name" if name else "file name")
    lines = read_local(path, file)
    if session.dry_run:
        command = UploadFile(session.channel, file, number or 0, tuple(lines))
        planned: list[Command[Any] | PlannedFrame] = [
            command,
            *(
                PlannedFrame(encode_packet(b"\x30" + body), f"FB line {i}")
                for i, body in enumerate(command.upload_bodies(), 1)
            ),
            PlannedFrame(encode_packet(b"\x34"), "FB end"),
        ]
        session.plan(planned, note="The JOB number is the file's own unless --number is given.")
    with _progress(session, f"uploading {file}") as progress:
        if file.is_job:
            session.client.upload_job(
                session.channel, file, lines, number=number, progress=progress
            )
        else:
            session.client.upload_points(
                session.channel, file, _points(lines), number=number, progress=progress
            )
    done(
        session,
        f"Uploaded {file} ({len(lines)} lines) to channel {session.channel}; "
        "it reads back the same.",
        name=str(file),
        lines=len(lines),
        channel=session.channel,
    )


@files.command("rm")
@click.argument("name")
@common_options(channel=True)
@pass_session
def files_rm(session: Session, name: str) -> None:
    """Delete JOB file NAME (FE); the controller does not delete PNT files.

    \b
    Example:
      robostar files rm OLD.JOB
    """
    file = _name(name)
    session.send(DeleteFile(session.channel, file))
    done(session, f"Deleted {file}.", name=str(file), channel=session.channel)


@files.command("cp")
@click.argument("name")
@click.argument("new_name")
@common_options(channel=True)
@pass_session
def files_cp(session: Session, name: str, new_name: str) -> None:
    """Copy file NAME to NEW_NAME on the same channel (FF).

    \b
    Example:
      robostar files cp DEMO.JOB COPY.JOB
    """
    source, target = _name(name), _name(new_name, "new name")
    session.send(CopyFile(session.channel, source, session.channel, target))
    done(session, f"Copied {source} to {target}.", name=str(source), new_name=str(target))


@files.command("mv")
@click.argument("name")
@click.argument("new_name")
@common_options(channel=True)
@pass_session
def files_mv(session: Session, name: str, new_name: str) -> None:
    """Rename file NAME to NEW_NAME (FG).

    \b
    Example:
      robostar files mv COPY.JOB NEW.JOB
    """
    source, target = _name(name), _name(new_name, "new name")
    session.send(RenameFile(session.channel, source, target))
    done(session, f"Renamed {source} to {target}.", name=str(source), new_name=str(target))


def _manifest_view(title: str, manifest: Any, folder: str) -> RenderableType:
    data = jsonable(manifest)
    entries = data.get("files", []) if isinstance(data, dict) else []
    table = Table(title=title, title_justify="left")
    for column in ("channel", "name", "bytes", "sha256"):
        table.add_column(column)
    for entry in entries:
        table.add_row(
            str(entry.get("channel", "")),
            str(entry.get("name", "")),
            str(entry.get("bytes", "")),
            str(entry.get("sha256", ""))[:16],
        )
    return Group(table, Text(f"{len(entries)} file(s); manifest in {folder}", style="green"))


@click.command()
@click.argument("folder", type=click.Path(file_okay=False))
@common_options()
@pass_session
def backup(session: Session, folder: str) -> None:
    """Save every JOB and PNT file of every channel to FOLDER, with a manifest (sha256).

    \b
    Example:
      robostar backup backups/line3-2024-05-01
    """
    if session.dry_run:
        session.plan([ListFiles(1, "*")], note="Then FA for every file listed, on every channel.")
    with _progress(session, "backup") as progress:
        manifest = session.client.backup(folder, progress=progress)
    session.out.result(
        {"ok": True, "folder": folder, "manifest": jsonable(manifest)},
        lambda: _manifest_view("Backup", manifest, folder),
    )


@click.command()
@click.argument("folder", type=click.Path(exists=True, file_okay=False))
@common_options()
@pass_session
def restore(session: Session, folder: str) -> None:
    """Upload every file of a backup in FOLDER, then read each back and compare.

    Files on the controller with the same names are overwritten.

    \b
    Example:
      robostar restore backups/line3-2024-05-01
    """
    if session.dry_run:
        session.plan(
            [ListFiles(1, "*")],
            note="Then FB for every file of the manifest, and FA to read each back.",
        )
    session.announce(
        f"Restoring {folder}: files of the same names on the controller are overwritten."
    )
    with _progress(session, "restore") as progress:
        manifest = session.client.restore(folder, progress=progress)
    session.out.result(
        {"ok": True, "folder": folder, "verified": True, "manifest": jsonable(manifest)},
        lambda: _manifest_view("Restored and verified", manifest, folder),
    )
