"""The jog page of one line and its socket (see :mod:`robostar.serve.faces.web.jog` for the
dead-man rules the socket keeps)."""

from __future__ import annotations

from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import BaseRoute, Route, WebSocketRoute
from starlette.websockets import WebSocket, WebSocketDisconnect

from robostar.commands.status import ReadPosition
from robostar.serve.faces.web.axes import channel_axes
from robostar.serve.faces.web.deps import STALE, Forbidden, deps_of, needs
from robostar.serve.faces.web.forms import file_name, int_field, json_body
from robostar.serve.faces.web.jog import INCH_STEPS, SILENCE, JogPanel
from robostar.serve.faces.web.points import write_point
from robostar.serve.faces.web.views import card, channels
from robostar.serve.http_guard import same_secret
from robostar.serve.lease import Who
from robostar.serve.users import Role
from robostar.types import PositionKind

__all__ = ["ROUTES"]


async def jog_page(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    axes = {number: channel_axes(line, number) for number in channels(line)}
    # one pad for every channel: a row per axis number, with its names on each channel that has it
    pad = [
        {
            "number": n,
            "names": {
                str(ch): {"joint": f"{a.joint} ({a.joint_unit})", "xy": f"{a.xy} ({a.xy_unit})"}
                for ch, found in axes.items()
                for a in found
                if a.number == n
            },
        }
        for n in sorted({a.number for found in axes.values() for a in found})
    ]
    return deps.page(
        request,
        "jog.html",
        line=line,
        card=card(line),
        axes=axes,
        pad=pad,
        steps=INCH_STEPS,
        silence=SILENCE,
    )


async def teach(request: Request) -> Response:
    """ "Teach here": the channel's joint position, read now, stored as point N of a PNT file
    (the point editor's code path: the file read, the point set, the file written back)."""
    deps = deps_of(request)
    line = deps.line_of(request)
    account = await deps.guard(request, Role.ENGINEER, line, "teach here")
    body = await json_body(request)
    if body.get("confirmed") is not True:
        raise Forbidden(428, "confirm the point to store first")
    channel = int_field(body.get("channel"), "channel", 1, 3)
    name = file_name(str(body.get("file", "")))
    if not name.is_points:
        raise Forbidden(400, f"{name}: teach into a point file (.PNT)")
    number = int_field(body.get("number"), "point", 0, 9999)
    here = await line.read(ReadPosition(channel, PositionKind.ANGLE), max_age=0)
    arm = (await line.read(ReadPosition(channel, PositionKind.XY), max_age=0)).arm
    axes = tuple(round(value, 3) for value in here.axes)
    change = await write_point(
        deps, line, account, channel, name, number, axes, arm=arm, why="teach here"
    )
    return JSONResponse(
        {
            "ok": True,
            "file": str(name),
            "point": number,
            "axes": list(change.new.axes),
            "old": None if change.old is None else list(change.old.axes),
        }
    )


async def jog_socket(websocket: WebSocket) -> None:
    """The jog panel's socket: only an operator, with the page's CSRF token, from this origin."""
    deps = deps_of(websocket)
    line = deps.server.lines.get(websocket.path_params["line"])
    account = deps.account(websocket)
    origin = websocket.headers.get("origin")
    host = websocket.headers.get("host")
    token = websocket.query_params.get("csrf")
    same_origin = origin is not None and host is not None and origin.split("://", 1)[-1] == host
    why = None
    if not same_origin:
        why = "the jog socket was opened from another origin"
    elif not same_secret(token, account.csrf):
        why = STALE
    elif not account.may(Role.OPERATOR):
        why = needs(Role.OPERATOR)
    if line is None or why is not None:
        if line is not None and why is not None:
            deps.refusals.record(line, "jog", Who(account.name, "web"), why)
        await websocket.close(code=4403)
        return
    await websocket.accept()

    def still_operator() -> bool:  # a sign-out, a removed user or a lowered role ends the jog
        return deps.account(websocket).may(Role.OPERATOR)

    session = JogPanel(line, Who(account.name, "web"), still_operator)
    try:
        await session.run(websocket)
    except WebSocketDisconnect:
        pass
    finally:
        await session.stop("the page went away")


ROUTES: list[BaseRoute] = [
    Route("/line/{line}/jog", jog_page),
    Route("/line/{line}/jog/teach", teach, methods=["POST"]),
    WebSocketRoute("/line/{line}/jog/ws", jog_socket),
]
