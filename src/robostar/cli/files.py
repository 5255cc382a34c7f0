"""Files on the controller: ``files ls|get|put|rm|cp|mv``, ``backup DIR`` and ``restore DIR``.

On disk a JOB file is its steps, one per line (MAIN to EOP); a PNT file is FA's point lines
(``P0001`` then 11 bytes per axis, ARM and USED), so a downloaded file uploads unchanged.
"""

from __future__ import annotations

import contextlib
import fnmatch
import os
import re
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

from robostar.backup import RestoreDiff
from robostar.cli.control import done
from robostar.cli.options import common_options
from robostar.cli.render import jsonable
from robostar.cli.session import ConsoleSession, PlannedFrame, pass_session
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
from robostar.commands.status import ReadInfo
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


XY_HEADER = "#COORDS XY"
"""First line of a point file saved with --xy: its coordinates are XY, not joint angles."""


_GLOB = re.compile(r"[A-Za-z0-9_.*?\[\]!-]+")


def read_local(path: Path, name: FileName) -> list[str]:
    """A local file's lines for upload; a PNT file's lines are checked as point lines."""
    try:
        text = path.read_text(encoding="ascii")
    except UnicodeDecodeError:
        raise UsageError(f"{path} holds non-ASCII bytes; the controller takes ASCII only") from None
    except OSError as error:
        raise UsageError(f"cannot read {path}: {error.strerror or error}") from None
    lines = [line.rstrip("\r") for line in text.splitlines()]
    if name.is_points and lines and lines[0].strip().upper() == XY_HEADER:
        raise UsageError(
            f"{path} holds points in XY (saved with --xy), but the controller's point files hold "
            "joint angles: uploading it would write millimetres as degrees. Download it again "
            "without --xy to upload it"
        )
    if name.is_points:
        return _point_lines(path, lines)
    # A blank line at the end is an editor's newline, not a step after EOP.
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        # An empty file (a failed `files get NAME - > file`) would replace the job with nothing.
        raise UsageError(f"{path} is empty; a JOB file holds its steps, MAIN to EOP")
    if lines[0].strip().upper() != "MAIN" or lines[-1].strip().upper() != "EOP":
        raise UsageError(
            f"{path} is not a whole job: a JOB file's steps start with MAIN and end with EOP, "
            f"and these start with {lines[0].strip()!r} and end with {lines[-1].strip()!r}"
        )
    return lines


def _point_lines(path: Path, lines: list[str]) -> list[str]:
    """A PNT file's point lines (blank lines dropped), each checked, no point given twice."""
    checked: list[str] = []
    first: dict[int, int] = {}  # point number -> the line of the file that gives it
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            point, _ = parse_point_line(line, command="FB", field=f"line {number}")
        except FieldError as error:
            raise UsageError(f"{path}: {error.field}: {error.message}") from None
        if point in first:
            # Uploaded as a mapping, the later line would silently replace the earlier one.
            raise UsageError(
                f"{path}: line {number}: point P{point:04d} is given again "
                f"(first on line {first[point]}); give each point once"
            )
        first[point] = number
        checked.append(line)
    return checked


def _points(lines: list[str]) -> dict[int, Point]:
    return dict(parse_point_line(line, command="FB") for line in lines)


@contextmanager
def _progress(session: ConsoleSession, label: str) -> Iterator[Callable[[int, int | None], None]]:
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
def files_ls(session: ConsoleSession, pattern: str) -> None:
    """List the channel's JOB and PNT files (FD): number, name, size, steps.

    PATTERN is a file name or a glob (*, ?, [...]), matched without regard to case; the
    controller's FD takes only * or one name, so a glob lists * and filters here.

    \b
    Example:
      robostar files ls
      robostar files ls '*.PNT'
      robostar --channel 2 files ls DEMO.JOB
    """
    if pattern == "*":
        records = session.send(ListFiles(session.channel, "*"))
    elif set(pattern) & set("*?["):
        if not _GLOB.fullmatch(pattern):
            raise UsageError(
                f"pattern {pattern!r}: a glob of letters, digits, _, ., *, ? and [...] only"
            )
        listed = session.send(ListFiles(session.channel, "*"))
        records = tuple(r for r in listed if fnmatch.fnmatchcase(r.name.upper(), pattern.upper()))
    else:
        records = session.send(ListFiles(session.channel, str(_name(pattern, "pattern"))))

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
def files_get(session: ConsoleSession, name: str, dest: str | None, xy: bool, force: bool) -> None:
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
    kind = "xy" if xy and file.is_points else "angle" if file.is_points else None
    if dest == "-" and session.out.json:
        # JSON keeps the point lines themselves; "coords" says which kind they are.
        session.out.result({"name": str(file), "coords": kind, "lines": lines})
        return
    if kind == "xy":
        # The kind travels with the file, on stdout too (it is often redirected to a file):
        # `files put` refuses it rather than write millimetres as degrees.
        lines = [XY_HEADER, *lines]
    text = "".join(line + "\n" for line in lines)
    if dest == "-":
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
        coords=kind,
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
def files_put(session: ConsoleSession, source: str, name: str | None, number: int | None) -> None:
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
    session.upload_total = len(lines)  # for the message if Ctrl-C cuts the upload short
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
def files_rm(session: ConsoleSession, name: str) -> None:
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
def files_cp(session: ConsoleSession, name: str, new_name: str) -> None:
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
def files_mv(session: ConsoleSession, name: str, new_name: str) -> None:
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
    return Group(
        table,
        Text(f"{len(entries)} file(s) and their manifest; the backup is in {folder}", "green"),
    )


@click.command()
@click.argument("folder", type=click.Path(file_okay=False))
@click.option(
    "--keep",
    type=click.IntRange(min=1),
    default=None,
    metavar="N",
    help="FOLDER holds timestamped generations (backup-<UTC time>); keep the newest N.",
)
@click.option(
    "--replace",
    is_flag=True,
    help="Replace a backup in FOLDER even if it was read from another target, or from a "
    "simulator by a controller's (or the other way round).",
)
@common_options()
@pass_session
def backup(session: ConsoleSession, folder: str, keep: int | None, replace: bool) -> None:
    """Save every JOB and PNT file of every channel to FOLDER, with a manifest (sha256).

    The backup is written to a temporary folder and swapped into place only when complete:
    an interrupted backup leaves the previous one intact. A non-empty FOLDER that is not a
    robostar backup is refused, and so is one holding anything besides the previous backup's
    own files (a backup replaces its folder whole). A previous backup of another target, or
    of a simulator when this is a controller (or the other way round), is replaced only with
    --replace.

    \b
    Example:
      robostar --port /dev/ttyUSB0 backup backups/line3
      robostar --robot cell1 backup backups/cell1 --keep 5
    """
    if session.dry_run:
        session.plan([ListFiles(1, "*")], note="Then FA for every file listed, on every channel.")
    try:
        with _progress(session, "backup") as progress:
            manifest = session.client.backup(folder, progress=progress, keep=keep, replace=replace)
    except KeyboardInterrupt:
        session.interrupt_note = (
            f"the backup was not finished and nothing of it was kept; what {folder} held "
            "before is intact (a backup only reads the controller)"
        )
        raise
    path = manifest.folder or folder
    session.out.result(
        {"ok": True, "folder": folder, "path": path, "keep": keep, "manifest": jsonable(manifest)},
        lambda: _manifest_view("Backup", manifest, path),
    )


@click.command()
@click.argument("folder", type=click.Path(exists=True, file_okay=False))
@click.option(
    "--dry-run",
    "preview",
    is_flag=True,
    help="Read the backup and the controller and print what would change; write nothing.",
)
@click.option(
    "--channel",
    "-c",
    "channels",
    type=click.IntRange(1, 3),
    multiple=True,
    help="Restore only this channel (repeatable); default all.",
)
@click.option("--only", metavar="PATTERN", help="Restore only files matching PATTERN (*.PNT).")
@click.option("--yes", "-y", is_flag=True, help="Do not ask for confirmation.")
@click.option(
    "--delete-extra",
    is_flag=True,
    help="Also delete JOB files on the controller that the backup does not hold.",
)
@click.option(
    "--ignore-identity",
    is_flag=True,
    help="Restore even if the controller's version, robot type or axes differ from the backup's.",
)
@common_options()
@pass_session
def restore(
    session: ConsoleSession,
    folder: str,
    preview: bool,
    channels: tuple[int, ...],
    only: str | None,
    yes: bool,
    delete_extra: bool,
    ignore_identity: bool,
) -> None:
    """Restore a backup in FOLDER: a preflight, a confirmation, then only what changed.

    The preflight validates the whole manifest, reads every file of the backup, and reads
    the controller (identity: version, robot type, axes; its files and their contents). If any
    check fails nothing is written. It then shows the diff (new, changed, unchanged, not in
    the backup) and asks before writing (--yes skips the question). Each file written is read
    back and compared.

    \b
    Example:
      robostar --port sim:// restore backups/line3 --dry-run
      robostar --robot cell1 restore backups/cell1 --channel 1 --only '*.PNT' --yes
    """
    if session.dry_run:
        session.plan(
            [ReadInfo(), ListFiles(1, "*")],
            note="Then FA of each file on both sides, FB of what changed, FA to read each back.",
        )
    if session.out.json and not (yes or preview):
        raise UsageError("--yes: a --json restore cannot ask; give --yes or --dry-run")
    channels = _restore_channels(channels)
    seen: list[tuple[RestoreDiff, bool]] = []

    def confirm(diff: RestoreDiff) -> bool:
        if preview:
            seen.append((diff, False))
            return False
        if not session.out.json:
            session.out.console.print(_diff_view(diff, folder))
        agreed = diff.writes == 0 or yes
        if not agreed:
            agreed = click.confirm(f"Write {diff.writes} file change(s) to {session.port}?")
        seen.append((diff, agreed))
        return agreed

    with _progress(session, "restore") as progress:
        manifest = session.client.restore(
            folder,
            progress=progress,
            channels=channels or None,
            only=only,
            dry_run=preview,
            confirm=confirm,
            delete_extra=delete_extra,
            ignore_identity=ignore_identity,
        )
    diff, agreed = seen[-1]
    written = agreed and diff.writes > 0
    data = {
        "ok": True,
        "folder": folder,
        "dry_run": preview,
        "written": written,
        "diff": _diff_json(diff),
        "manifest": jsonable(manifest),
    }
    if preview:
        session.out.result(data, lambda: _diff_view(diff, folder))
    elif not agreed:
        session.out.result(data, Text("Nothing was written.", style="yellow"))
        raise click.exceptions.Exit(1)
    else:
        session.out.result(
            data, Text(f"Restored {diff.writes} file change(s) and verified them.", style="green")
        )


def _restore_channels(own: tuple[int, ...]) -> tuple[int, ...]:
    """The channels to restore: restore's own --channel, else the global one when it was given
    (`robostar -c 2 restore DIR` means channel 2, as for every other command), else all."""
    root = click.get_current_context().find_root()
    if root.get_parameter_source("channel") is not click.core.ParameterSource.COMMANDLINE:
        return own
    given = int(root.params["channel"])
    if own and given not in own:
        raise UsageError(
            f"--channel: -c {given} before the command and --channel "
            f"{', '.join(map(str, own))} after it disagree; give the channels once, after "
            "`restore` (nothing was written)"
        )
    return own or (given,)


def _diff_json(diff: RestoreDiff) -> dict[str, object]:
    return {
        "new": list(diff.new),
        "changed": list(diff.changed),
        "unchanged": list(diff.unchanged),
        "not_in_backup": list(diff.extra),
        "would_be_deleted": list(diff.delete),
        "identity_differences": list(diff.identity),
    }


def _diff_view(diff: RestoreDiff, folder: str) -> RenderableType:
    table = Table(title=f"Restore of {folder}: what changes", title_justify="left")
    table.add_column("file")
    table.add_column("on the controller")
    rows = [
        *((f, Text("new: will be written", "green")) for f in diff.new),
        *((f, Text("changed: will be overwritten", "yellow")) for f in diff.changed),
        *((f, Text("unchanged: left alone", "dim")) for f in diff.unchanged),
        *((f, Text("would be deleted", "bold red")) for f in diff.delete),
        *((f, Text("not in the backup: kept", "dim")) for f in diff.extra if f not in diff.delete),
    ]
    for name, state in rows:
        table.add_row(name, state)
    parts: list[RenderableType] = [table]
    for problem in diff.identity:
        parts.append(Text(f"identity differs (--ignore-identity): {problem}", "yellow"))
    parts.append(
        Text(
            f"{len(diff.new)} new, {len(diff.changed)} changed, {len(diff.unchanged)} unchanged, "
            f"{len(diff.delete)} to delete, {len(diff.extra) - len(diff.delete)} kept",
            style="bold",
        )
    )
    return Group(*parts)


# -- programs under change control (the line server's version store) ----------------------------
def _store(store_dir: str | None) -> Any:
    from robostar.serve.config import default_audit_path
    from robostar.serve.programs import ProgramStore

    root = Path(store_dir) if store_dir else default_audit_path().parent / "programs"
    if not root.is_dir():
        raise UsageError(
            f"no program versions in {root}: the line server keeps them beside its audit log "
            "(give the folder with --store)"
        )
    return ProgramStore(root)


def _store_line(store: Any, line: str | None) -> str:
    known: list[str] = store.lines()
    if line is not None:
        if line not in known:
            raise UsageError(f"--line {line}: no versions kept for it (lines: {', '.join(known)})")
        return line
    if len(known) != 1:
        raise UsageError(f"give --line: versions are kept for {', '.join(known) or 'no line'}")
    return known[0]


_STORE_OPTIONS = (
    click.option("--line", "line_name", help="The line (default: the only one with versions)."),
    click.option(
        "--store",
        "store_dir",
        type=click.Path(file_okay=False),
        help="The line server's programs folder (default: beside its default audit log).",
    ),
)


def _store_options(func: Any) -> Any:
    for option in reversed(_STORE_OPTIONS):
        func = option(func)
    return func


@files.command("history")
@click.argument("name")
@_store_options
@common_options(channel=True)
@pass_session
def files_history(
    session: ConsoleSession, name: str, line_name: str | None, store_dir: str | None
) -> None:
    """The versions the line server kept of file NAME: when, who, how, size and hash.

    \b
    Example:
      robostar files history DEMO.JOB --line cell1
    """
    import time

    file = _name(name)
    store = _store(store_dir)
    line = _store_line(store, line_name)
    versions = store.versions(line, session.channel, file)
    rows = [
        {"version": len(versions) - i, **{k: getattr(v, k) for k in v.__slots__}}
        for i, v in enumerate(versions)
    ]
    table = Table(title=f"{file} on {line}, channel {session.channel}")
    for column in ("Version", "When", "Who", "How", "Bytes", "SHA-256"):
        table.add_column(column)
    for row, v in zip(rows, versions, strict=True):
        when = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(v.at))
        table.add_row(
            f"v{row['version']}", when, f"{v.who} ({v.face})", v.how, str(v.size), v.short
        )
    shown: RenderableType = table
    if not versions:
        shown = Text(f"No versions of {file} kept for {line} channel {session.channel}.")
    session.out.result({"name": str(file), "line": line, "versions": rows}, shown)


@files.command("diff")
@click.argument("name")
@click.argument("old", required=False, default="-2")
@click.argument("new", required=False, default="-1")
@click.option(
    "--current",
    is_flag=True,
    help="Compare the last version with the file on the controller now (reads it over --port).",
)
@_store_options
@common_options(channel=True)
@pass_session
def files_diff(
    session: ConsoleSession,
    name: str,
    old: str,
    new: str,
    current: bool,
    line_name: str | None,
    store_dir: str | None,
) -> None:
    """A line diff of two kept versions of NAME (numbers from `files history`, negative from
    the newest, or hash prefixes; default: the last two), or with --current of the last
    version and the controller's file now.

    \b
    Example:
      robostar files diff DEMO.JOB 3 5 --line cell1
      robostar --port tcp://10.0.0.5:20000 files diff DEMO.JOB --current
    """
    from robostar.serve.programs import diff_lines

    file = _name(name)
    store = _store(store_dir)
    line = _store_line(store, line_name)
    if current:
        last = store.find(line, session.channel, file, "-1")
        old_text, old_label = store.text(last.hash), f"version {last.short}"
        if file.is_job:
            content: JobFile | PointFile = session.client.download_job(session.channel, file)
        else:
            content = session.client.download_points(session.channel, file, coords="angle")
        new_text = "".join(f"{line}\n" for line in file_lines(content))
        new_label = "on the controller now"
    else:
        a = store.find(line, session.channel, file, old)
        b = store.find(line, session.channel, file, new)
        old_text, old_label = store.text(a.hash), f"version {a.short}"
        new_text, new_label = store.text(b.hash), f"version {b.short}"
    diff = diff_lines(old_text, new_text, old_label, new_label)
    shown = Text("\n".join(diff)) if diff else Text("No differences.")
    session.out.result({"name": str(file), "old": old_label, "new": new_label, "diff": diff}, shown)
