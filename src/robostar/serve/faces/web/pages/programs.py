"""Programs under change control: a file's versions, a line diff between any two of them (or
the controller's current file), "restore this version" (engineer, preview, confirm, audited),
and the check for files changed at the pendant. The store is serve/programs.py."""

from __future__ import annotations

from starlette.requests import Request
from starlette.responses import RedirectResponse, Response
from starlette.routing import BaseRoute, Route

from robostar.commands.files import DownloadFile, ListFiles, UploadFile
from robostar.errors import UsageError
from robostar.protocol.fields import FileName
from robostar.serve.faces.web.auth import read_form
from robostar.serve.faces.web.deps import Forbidden, WebDeps, deps_of
from robostar.serve.faces.web.forms import file_params
from robostar.serve.faces.web.points import keep_download
from robostar.serve.faces.web.views import channels
from robostar.serve.lease import Who
from robostar.serve.line import Line
from robostar.serve.programs import Version, check, diff_lines, program_text
from robostar.serve.users import Role
from robostar.types import CoordSystem

__all__ = ["ROUTES"]

CURRENT = "current"
"""The reference of the controller's file as it is now (downloaded when asked for)."""


def _find(deps: WebDeps, line: Line, channel: int, name: FileName, ref: str) -> Version:
    try:
        return deps.store.find(line.name, channel, name, ref)
    except UsageError as exc:
        raise Forbidden(404, str(exc)) from None


async def _current(
    deps: WebDeps, request: Request, line: Line, channel: int, name: FileName
) -> str:
    account = deps.signed_in(request, line, "file view")
    with deps.one_transfer(line):
        content = await line.read(DownloadFile(channel, name, CoordSystem.ANGLE), max_age=0)
    keep_download(deps, line, channel, name, content, Who(account.name, "web"))
    return program_text(content)


async def _text(
    deps: WebDeps, request: Request, line: Line, channel: int, name: FileName, ref: str
) -> tuple[str, str]:
    """The text of a reference (a version or the controller's current file) and its label."""
    if ref == CURRENT:
        return await _current(deps, request, line, channel, name), "on the controller now"
    version = _find(deps, line, channel, name, ref)
    return deps.store.text(version.hash), f"version {version.short}"


async def versions(request: Request) -> Response:
    """The file's versions, newest first, and the diff the page asks for (``?a=&b=``)."""
    deps = deps_of(request)
    line = deps.line_of(request)
    channel, name = file_params(request)
    deps.signed_in(request, line, "file versions")
    query = request.query_params
    a, b = query.get("a"), query.get("b")
    diff = None
    labels = None
    if a and b:
        old, old_label = await _text(deps, request, line, channel, name, a)
        new, new_label = await _text(deps, request, line, channel, name, b)
        diff = diff_lines(old, new, old_label, new_label)
        labels = (old_label, new_label)
    # after the diff: reading the controller's file may have kept a new version
    history = deps.store.versions(line.name, channel, name)
    numbered = [(len(history) - i, v) for i, v in enumerate(history)]
    return deps.page(
        request,
        "versions.html",
        line=line,
        channel=channel,
        name=str(name),
        versions=numbered,
        diff=diff,
        labels=labels,
        a=a,
        b=b,
    )


async def version_text(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    channel, name = file_params(request)
    deps.signed_in(request, line, "file versions")
    version = _find(deps, line, channel, name, request.path_params["ref"])
    return Response(deps.store.text(version.hash), media_type="text/plain; charset=utf-8")


async def restore_preview(request: Request) -> Response:
    """What restoring a version would write: its text and its diff from the controller's file."""
    deps = deps_of(request)
    line = deps.line_of(request)
    await deps.guard(request, Role.ENGINEER, line, "restore")
    channel, name = file_params(request)
    form = await read_form(request)
    version = _find(deps, line, channel, name, str(form.get("version", "")))
    text = deps.store.text(version.hash)
    current = await _current(deps, request, line, channel, name)
    diff = diff_lines(current, text, "on the controller now", f"version {version.short}")
    return deps.page(
        request,
        "restore.html",
        line=line,
        channel=channel,
        name=str(name),
        version=version,
        text=text,
        diff=diff,
    )


async def restore_confirm(request: Request) -> Response:
    """Write a kept version back to the controller (FB, under its JOB number), audited."""
    deps = deps_of(request)
    line = deps.line_of(request)
    account = await deps.guard(request, Role.ENGINEER, line, "restore")
    channel, name = file_params(request)
    form = await read_form(request)
    if form.get("confirmed") != "yes":
        raise Forbidden(428, "confirm the restore on its preview page")
    version = _find(deps, line, channel, name, str(form.get("version", "")))
    lines = tuple(deps.store.text(version.hash).splitlines())
    records = await line.read(ListFiles(channel, "*"), max_age=0)
    job_number = next((r.job_number for r in records if r.name == str(name)), 0)
    await deps.run(line, UploadFile(channel, name, job_number, lines), account)
    who = Who(account.name, "web")
    line.record(
        f"restore {name} on channel {channel} to version {version.short}"
        f" ({version.size} bytes, kept by {version.who} at {version.at:.0f} from {version.how})",
        who,
        "ok",
    )
    deps.keep(line, channel, name, deps.store.text(version.hash), who, "restore")
    return RedirectResponse(
        f"/line/{line.name}/files/{channel}/{name}/versions?restored={version.short}",
        status_code=303,
    )


async def check_page(request: Request) -> Response:
    """Has anything changed on the controller that did not go through the server? (FD, then
    FA of every file: a transfer, for a signed-in user, asked with the page's token.)"""
    deps = deps_of(request)
    line = deps.line_of(request)
    account = await deps.guard(request, Role.VIEWER, line, "program check")
    with deps.one_transfer(line):
        drift = await check(deps.store, line, channels(line), Who(account.name, "web"))
    flagged = sum(1 for d in drift if d.state != "same")
    line.record(
        f"program check: {len(drift)} files, {flagged} changed, new or gone outside the server",
        Who(account.name, "web"),
        "ok",
    )
    return deps.page(request, "check.html", line=line, drift=drift, flagged=flagged)


ROUTES: list[BaseRoute] = [
    Route("/line/{line}/files/{channel:int}/{name}/versions", versions),
    Route("/line/{line}/files/{channel:int}/{name}/versions/{ref}/text", version_text),
    Route(
        "/line/{line}/files/{channel:int}/{name}/versions/restore",
        restore_preview,
        methods=["POST"],
    ),
    Route(
        "/line/{line}/files/{channel:int}/{name}/versions/restore/confirm",
        restore_confirm,
        methods=["POST"],
    ),
    Route("/line/{line}/programs/check", check_page, methods=["POST"]),
]
