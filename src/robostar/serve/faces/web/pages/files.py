"""The files page of one line: the listing per channel, a file's view and download, the point
editor, the upload (preview, then confirm) and the backup of every file as a zip."""

from __future__ import annotations

import io
import time
import zipfile
from collections.abc import Mapping
from typing import Any

from starlette.requests import Request
from starlette.responses import RedirectResponse, Response
from starlette.routing import BaseRoute, Route

from robostar.commands.files import DownloadFile, ListFiles, UploadFile
from robostar.errors import RobostarError
from robostar.protocol.fields import FileName
from robostar.serve.faces.web.auth import read_form
from robostar.serve.faces.web.axes import channel_axes
from robostar.serve.faces.web.deps import Forbidden, WebDeps, deps_of
from robostar.serve.faces.web.forms import (
    coordinate,
    file_name,
    file_params,
    file_text,
    int_field,
    steps,
)
from robostar.serve.faces.web.limits import MAX_UPLOAD, upload_too_large
from robostar.serve.faces.web.points import axes_of, keep_download, read_points, write_point
from robostar.serve.faces.web.views import channels
from robostar.serve.lease import Who
from robostar.serve.line import Line
from robostar.serve.programs import program_text, text_of_lines
from robostar.serve.users import Role
from robostar.types import CoordSystem, FileRecord, JobFile, PointFile

__all__ = ["ROUTES"]


async def files(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    shown = channels(line)
    channel = int_field(request.query_params.get("channel", str(shown[0])), "channel", 1, 3)
    listing: tuple[FileRecord, ...] = ()
    error = None
    if channel not in shown:
        error = f"line {line.name} has no channel {channel}: it has {', '.join(map(str, shown))}"
    elif not deps.account(request).may(Role.VIEWER):
        # FD is a transfer too (up to 403 packets): not for a GET any page can fire
        error = "Sign in to list the files: the list is read from the controller."
    else:
        try:
            with deps.one_transfer(line):
                listing = await line.read(ListFiles(channel, "*"))
        except Forbidden as exc:
            error = exc.message
        except RobostarError as exc:
            error = str(exc)
    return deps.page(
        request,
        "files.html",
        line=line,
        channel=channel,
        channels=shown,
        files=listing,
        error=error,
    )


async def file_view(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    channel, name = file_params(request)  # a bad name is a 400 for anyone: nothing sent
    deps.signed_in(request, line, "file view")
    coords = CoordSystem.XY if request.query_params.get("coords") == "xy" else CoordSystem.ANGLE
    return await _file_page(request, line, channel, name, coords)


async def _file_page(
    request: Request,
    line: Line,
    channel: int,
    name: FileName,
    coords: CoordSystem,
    *,
    error: str | None = None,
    entered: Mapping[str, str] | None = None,
    status: int = 200,
) -> Response:
    """A file's page; for a PNT file in angles, the point editor with its fields filled: with
    what was entered (after a refusal), else with the point ``?edit=N`` (or the first)."""
    deps = deps_of(request)
    with deps.one_transfer(line):
        content = await line.read(DownloadFile(channel, name, coords))
    if coords is CoordSystem.ANGLE:
        keep_download(deps, line, channel, name, content, _who(deps, request))
    editor = None
    if isinstance(content, PointFile) and coords is CoordSystem.ANGLE:
        editor = _editor(line, channel, content, request.query_params.get("edit"), entered)
    response = deps.page(
        request,
        "file.html",
        line=line,
        channel=channel,
        name=str(name),
        job=content if isinstance(content, JobFile) else None,
        points=content if isinstance(content, PointFile) else None,
        coords=coords.name.lower(),
        size=len(file_text(content).encode("ascii", "replace")),
        editor=editor,
        error=error,
    )
    response.status_code = status
    return response


def _who(deps: WebDeps, request: Request) -> Who:
    return Who(deps.account(request).name, "web")


def _editor(
    line: Line,
    channel: int,
    content: PointFile,
    asked: str | None,
    entered: Mapping[str, str] | None,
) -> dict[str, Any]:
    count = axes_of(content)
    names = {a.number: f"{a.joint} ({a.joint_unit})" for a in channel_axes(line, channel)}
    table = {
        str(n): [f"{v:.3f}" for v in p.axes] for n, p in sorted(content.points.items()) if p.used
    }
    if entered is not None:
        number = entered.get("number", "")
        values = [entered.get(f"axis{i}", "") for i in range(1, count + 1)]
    else:
        number = asked if asked in table else next(iter(table), "1")
        values = table.get(number, [""] * count)
    return {
        "number": number,
        "axes": [
            {"index": i, "label": names.get(i, f"Axis {i}"), "value": values[i - 1]}
            for i in range(1, count + 1)
        ],
        "table": table,
    }


async def file_download(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    channel, name = file_params(request)  # a bad name is a 400 for anyone: nothing sent
    account = deps.signed_in(request, line, "file download")
    with deps.one_transfer(line):
        content = await line.read(DownloadFile(channel, name, CoordSystem.ANGLE))
    keep_download(deps, line, channel, name, content, Who(account.name, "web"))
    return Response(
        file_text(content),
        media_type="text/plain; charset=utf-8",
        headers={"content-disposition": f'attachment; filename="{name}"'},
    )


async def point_edit(request: Request) -> Response:
    """The point table editor: one point of a PNT file changed, the file written back (FB).
    A refusal is shown on the file's page, in words, with what was entered (a browser), or as
    JSON (any other client)."""
    deps = deps_of(request)
    line = deps.line_of(request)
    account = await deps.guard(request, Role.ENGINEER, line, "point edit")
    channel, name = file_params(request)
    form = await read_form(request)
    try:
        if form.get("confirmed") != "yes":
            raise Forbidden(428, "confirm the change of the point first")
        if not name.is_points:
            raise Forbidden(400, f"{name} is not a point file")
        number = int_field(form.get("number"), "point", 0, 9999)
        content = await read_points(line, channel, name)
        old = content.points.get(number)
        count = len(old.axes) if old is not None else axes_of(content)
        axes = tuple(coordinate(form.get(f"axis{i}"), f"axis {i}") for i in range(1, count + 1))
        await write_point(deps, line, account, channel, name, number, axes, content)
    except (Forbidden, RobostarError) as exc:
        if "text/html" not in request.headers.get("accept", "") or not name.is_points:
            raise
        status = exc.status if isinstance(exc, Forbidden) else 409
        why = exc.message if isinstance(exc, Forbidden) else str(exc)
        entered = {k: v for k, v in form.items() if isinstance(v, str)}
        return await _file_page(
            request,
            line,
            channel,
            name,
            CoordSystem.ANGLE,
            error=f"The point was not written: {why}.",
            entered=entered,
            status=status,
        )
    return RedirectResponse(
        f"/line/{line.name}/files/{channel}/{name}?saved={number}&edit={number}", status_code=303
    )


async def backup_zip(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    who = Who(deps.signed_in(request, line, "backup").name, "web")
    buffer = io.BytesIO()
    with deps.one_transfer(line), zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for channel in channels(line):
            for record in await line.read(ListFiles(channel, "*")):
                name = FileName.parse(record.name)
                content = await line.read(DownloadFile(channel, name, CoordSystem.ANGLE))
                archive.writestr(f"ch{channel}/{name}", file_text(content))
                deps.keep(line, channel, name, program_text(content), who, "backup")
    stamp = time.strftime("%Y%m%d-%H%M%S")
    return Response(
        buffer.getvalue(),
        media_type="application/zip",
        headers={"content-disposition": f'attachment; filename="{line.name}-{stamp}.zip"'},
    )


async def upload_preview(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    await deps.guard(request, Role.ENGINEER, line, "file upload")
    form = await read_form(request)
    channel = int_field(str(form.get("channel", "1")), "channel", 1, 3)
    upload = form.get("file")
    if upload is None or isinstance(upload, str):
        raise Forbidden(400, "choose a file to upload")
    raw = await upload.read(MAX_UPLOAD + 1)
    if len(raw) > MAX_UPLOAD:
        raise Forbidden(413, upload_too_large("the file"))
    try:
        text = raw.decode("ascii")
    except UnicodeDecodeError:
        raise Forbidden(400, "the controller holds ASCII text only") from None
    name = file_name(str(form.get("name") or upload.filename or ""))
    lines = steps(name, text)
    command = UploadFile(
        channel, name, int_field(str(form.get("job_number", "0")), "job", 0, 200), lines
    )
    command.encode()  # every line checked now: a bad one is refused before the preview
    return deps.page(
        request,
        "upload.html",
        line=line,
        channel=channel,
        name=str(name),
        job_number=command.job_number,
        lines=lines,
        content=text,
    )


async def upload_confirm(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    account = await deps.guard(request, Role.ENGINEER, line, "file upload")
    form = await read_form(request)
    if form.get("confirmed") != "yes":
        raise Forbidden(428, "confirm the upload on its preview page")
    channel = int_field(str(form.get("channel", "1")), "channel", 1, 3)
    name = file_name(str(form.get("name", "")))
    job_number = int_field(str(form.get("job_number", "0")), "job", 0, 200)
    content = str(form.get("content", ""))
    if len(content) > MAX_UPLOAD:  # the preview's limit, for a confirm sent without one
        raise Forbidden(413, upload_too_large("the content"))
    lines = steps(name, content)
    await deps.run(line, UploadFile(channel, name, job_number, lines), account)
    deps.keep(line, channel, name, text_of_lines(lines), Who(account.name, "web"), "upload")
    return RedirectResponse(f"/line/{line.name}/files?channel={channel}", status_code=303)


ROUTES: list[BaseRoute] = [
    Route("/line/{line}/files", files),
    Route("/line/{line}/files/upload", upload_preview, methods=["POST"]),
    Route("/line/{line}/files/upload/confirm", upload_confirm, methods=["POST"]),
    Route("/line/{line}/files/{channel:int}/{name}", file_view),
    Route("/line/{line}/files/{channel:int}/{name}/download", file_download),
    Route("/line/{line}/files/{channel:int}/{name}/point", point_edit, methods=["POST"]),
    Route("/line/{line}/backup.zip", backup_zip),
]
