"""The controller page of one line: lamps, positions, I/O, alarms, and the operator's actions
(servo, job start and stop, speed, outputs, alarm reset, emergency stop)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import BaseRoute, Route

from robostar.commands.base import Command
from robostar.commands.control import EmergencyStop, ResetAlarms, SetSpeed, StartJob, StopJob
from robostar.commands.files import DownloadFile, ListFiles
from robostar.commands.io import SetOutput
from robostar.commands.job import SelectJob, Servo, SetJobMode
from robostar.commands.motion import Home
from robostar.errors import RobostarError
from robostar.protocol.fields import FileName
from robostar.serve.faces.web.axes import channel_axes
from robostar.serve.faces.web.deps import Forbidden, deps_of, needs
from robostar.serve.faces.web.forms import file_name, int_field, json_body
from robostar.serve.faces.web.views import card, channels, detail
from robostar.serve.faces.web.workspace import Cache, read_workspace
from robostar.serve.jsonable import jsonable
from robostar.serve.line import Line
from robostar.serve.users import Role
from robostar.types import CoordSystem, JobMode, PointFile

__all__ = ["ACTIONS", "ROUTES"]


TRAIL_SECONDS = 30
"""How much of the tool's path the XY view keeps."""


async def controller(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    cache: Cache = deps.extras.setdefault("workspaces", {})
    views: dict[int, dict[str, Any]] = {}
    for number in channels(line):
        found = await read_workspace(line, number, cache)
        views[number] = {
            "workspace": None if found is None else {"outlines": found.outlines, "box": found.box},
            "points": [],
            "trail": TRAIL_SECONDS,
        }
    shown, error = await _taught_points(request, line, views)
    axes = {number: channel_axes(line, number) for number in channels(line)}
    return deps.page(
        request,
        "controller.html",
        line=line,
        card=card(line),
        detail=detail(line),
        axes=axes,
        views=views,
        shown_points=shown,
        points_error=error,
    )


async def _taught_points(
    request: Request, line: Line, views: dict[int, dict[str, Any]]
) -> tuple[str | None, str | None]:
    """The points of the PNT file the page asks for (``?points=NAME&pch=N``), in XY, as markers
    of that channel's view: a download, so for a signed-in user only."""
    deps = deps_of(request)
    asked = request.query_params.get("points")
    if not asked:
        return None, None
    channel = int_field(request.query_params.get("pch", "1"), "channel", 1, 3)
    name = file_name(asked)
    if not name.is_points or channel not in views:
        return str(name), f"{name}: choose a point file (.PNT) of channel 1-{max(views)}"
    deps.signed_in(request, line, "file view")
    try:
        with deps.one_transfer(line):
            content = await line.read(DownloadFile(channel, name, CoordSystem.XY))
    except (Forbidden, RobostarError) as exc:
        return str(name), str(getattr(exc, "message", exc))
    if isinstance(content, PointFile):
        views[channel]["points"] = [
            {"n": number, "x": point.axes[0], "y": point.axes[1]}
            for number, point in sorted(content.points.items())
            if point.used and len(point.axes) >= 2
        ]
    return str(name), None


@dataclass(frozen=True, slots=True)
class Action:
    """An action: the role it needs and the command(s) it sends, in order, from the body."""

    role: Role
    build: Callable[[dict[str, Any]], Command[Any] | tuple[Command[Any], ...]]


def _channel(body: dict[str, Any]) -> int:
    return int_field(body.get("channel"), "channel", 1, 3)


def _on(body: dict[str, Any]) -> bool:
    value = body.get("on")
    if not isinstance(value, bool):
        raise Forbidden(400, "on: true or false")
    return value


def _job(body: dict[str, Any]) -> FileName:
    name = file_name(str(body.get("job", "")))
    if not name.is_job:
        raise Forbidden(400, f"{name}: choose a JOB file")
    return name


def _permille(body: dict[str, Any]) -> int:
    """The speed as the wire carries it (0-1000, 1000 = 100 %), from ``percent`` (0-100, to
    0.1) or, as before, ``speed`` in per mille."""
    if "percent" not in body:
        return int_field(body.get("speed"), "speed", 0, 1000)
    value = body.get("percent")
    try:
        percent = float(str(value))
    except ValueError:
        raise Forbidden(400, f"speed: a percentage 0-100, not {value!r}") from None
    if isinstance(value, bool) or not 0 <= percent <= 100:
        raise Forbidden(400, f"speed: {value!r} is not a percentage 0-100")
    return round(percent * 10)


ACTIONS: dict[str, Action] = {
    "servo": Action(Role.OPERATOR, lambda b: Servo(_channel(b), _on(b))),
    "home": Action(Role.OPERATOR, lambda b: Home(_channel(b))),
    "job_select": Action(Role.OPERATOR, lambda b: SelectJob(_channel(b), _job(b))),
    "job_start": Action(Role.OPERATOR, lambda b: StartJob(_channel(b))),
    # one step: STEP mode (hold after each step), then start: the job runs its next step
    "job_step": Action(
        Role.OPERATOR,
        lambda b: (SetJobMode(_channel(b), JobMode.STEP), StartJob(_channel(b))),
    ),
    "job_auto": Action(Role.OPERATOR, lambda b: SetJobMode(_channel(b), JobMode.AUTO)),
    "job_stop": Action(Role.OPERATOR, lambda b: StopJob(_channel(b))),
    "reset_alarms": Action(Role.OPERATOR, lambda b: ResetAlarms()),
    "emergency_stop": Action(Role.OPERATOR, lambda b: EmergencyStop()),
    "speed": Action(Role.OPERATOR, lambda b: SetSpeed(_channel(b), _permille(b))),
    "output": Action(
        Role.OPERATOR,
        lambda b: SetOutput(
            int_field(b.get("port"), "port", 0, 4),
            int_field(b.get("contact"), "contact", 0, 15),
            _on(b),
        ),
    ),
}

ACTION_ROLE = min(spec.role for spec in ACTIONS.values())
"""The role every action needs at least (checked before the body is read)."""


async def action(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    # the role every action needs and the CSRF header, before the body is read
    account = await deps.guard(request, ACTION_ROLE, line, "action")
    body = await json_body(request)
    name = str(body.get("action", ""))
    spec = ACTIONS.get(name)
    if spec is None:
        raise Forbidden(400, f"unknown action {name!r}")
    if not account.may(spec.role):
        deps.refuse(line, account, f"action {name}", 403, needs(spec.role))
    if body.get("confirmed") is not True:
        raise Forbidden(428, f"{name}: confirm it first")
    built = spec.build(body)
    commands = built if isinstance(built, tuple) else (built,)
    for command in commands:
        command.encode()  # every command checked before the first is sent
    result = None
    for command in commands:
        result = await deps.run(line, command, account)
    return JSONResponse({"ok": True, "action": name, "result": jsonable(result)})


async def jobs(request: Request) -> Response:
    """The JOB files of a channel, by name and number (FD: a transfer, for signed-in users)."""
    deps = deps_of(request)
    line = deps.line_of(request)
    channel = int_field(request.path_params["channel"], "channel", 1, 3)
    if channel not in channels(line):
        raise Forbidden(404, f"line {line.name} has no channel {channel}")
    deps.signed_in(request, line, "job list")
    with deps.one_transfer(line):
        records = await line.read(ListFiles(channel, "*"))
    found = [
        {"name": r.name, "number": r.job_number, "steps": r.steps}
        for r in records
        if r.name.upper().endswith(".JOB")
    ]
    return JSONResponse({"channel": channel, "jobs": sorted(found, key=lambda j: j["number"])})


ROUTES: list[BaseRoute] = [
    Route("/line/{line}", controller),
    Route("/line/{line}/action", action, methods=["POST"]),
    Route("/line/{line}/jobs/{channel:int}", jobs),
]
