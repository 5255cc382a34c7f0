"""The jog page of one line and its socket (see :mod:`robostar.serve.faces.web.jog` for the
dead-man rules the socket keeps)."""

from __future__ import annotations

from starlette.requests import Request
from starlette.responses import Response
from starlette.routing import BaseRoute, Route, WebSocketRoute
from starlette.websockets import WebSocket, WebSocketDisconnect

from robostar.serve.faces.web.deps import STALE, deps_of, needs
from robostar.serve.faces.web.jog import JogPanel
from robostar.serve.faces.web.views import card
from robostar.serve.http_guard import same_secret
from robostar.serve.lease import Who
from robostar.serve.users import Role

__all__ = ["ROUTES"]


async def jog_page(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    return deps.page(request, "jog.html", line=line, card=card(line))


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
    WebSocketRoute("/line/{line}/jog/ws", jog_socket),
]
