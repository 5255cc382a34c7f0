"""The dashboard as a Starlette application: its pages, the guards around them, its errors.

Everything is server-rendered (Jinja2) from the line server's model, and kept live by one
Server-Sent Events stream per browser (``/events``), fed by a bounded subscription of its own, so
a slow or frozen browser never slows the others or the line. State changes are POSTs that carry
the session's CSRF token and an explicit confirmation, need a role, and go through the line
server (lease and audit). Assets are served by the package: no CDN, plants are offline.

The pages are modules of :mod:`robostar.serve.faces.web.pages`, one each; what they share (the
server, users, sessions, limits) is one :class:`~robostar.serve.faces.web.deps.WebDeps`.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from types import ModuleType

from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.middleware.sessions import SessionMiddleware
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, Response
from starlette.routing import BaseRoute, Mount
from starlette.staticfiles import StaticFiles

from robostar.errors import RobostarError
from robostar.serve.faces.web import pages as all_pages
from robostar.serve.faces.web.auth import SESSION_LIFETIME
from robostar.serve.faces.web.deps import Forbidden, WebDeps, WebSettings, templates
from robostar.serve.faces.web.limits import MAX_UPLOAD_BODY, UPLOAD_ROUTES, upload_too_large
from robostar.serve.http_guard import BodyLimit, BodyTooLarge, HostGuard, HostRule, RouteLimit
from robostar.serve.line import LineBusyError, LineDownError
from robostar.serve.line_server import LineServer

__all__ = ["WebSettings", "build_app"]

_HERE = Path(__file__).parent


def build_app(
    server: LineServer, settings: WebSettings, pages: Iterable[ModuleType] = all_pages.ALL
) -> Starlette:
    """The dashboard of ``server``'s lines: ``pages`` (each a module with ``ROUTES``), every
    one behind the same host check, body limits and sessions."""
    deps = WebDeps(server, settings, templates())
    routes: list[BaseRoute] = [route for page in pages for route in page.ROUTES]
    routes.append(Mount("/static", StaticFiles(directory=str(_HERE / "static")), name="static"))
    middleware = [
        Middleware(
            HostGuard,
            rule=HostRule(settings.listen_host, settings.hosts),
            respond=_guard_error,
        ),
        Middleware(
            BodyLimit,
            limit=settings.max_body,
            respond=_guard_error,
            # the largest legitimate body is the largest file the protocol carries; every other
            # route is held to max_body (a sign-in, an action or a point: a few hundred bytes)
            routes=(RouteLimit(UPLOAD_ROUTES, MAX_UPLOAD_BODY, upload_too_large("the upload")),),
        ),
        Middleware(
            SessionMiddleware,
            secret_key=settings.secret,
            session_cookie="robostar_session",
            same_site="strict",
            https_only=settings.https_only,
            max_age=int(SESSION_LIFETIME),
        ),
    ]
    app = Starlette(
        routes=routes,
        middleware=middleware,
        exception_handlers={
            BodyTooLarge: _too_large_response,
            Forbidden: _forbidden_response,
            RobostarError: _robostar_error_response,
        },
    )
    app.state.deps = deps
    app.state.sessions = deps.sessions
    app.state.transferring = deps.transferring
    return app


async def _forbidden_response(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, Forbidden)
    return _error(request, exc.status, exc.message)


async def _too_large_response(request: Request, exc: Exception) -> Response:
    # a body without a length that grew past the limit (BodyLimit counted it)
    return _guard_error(413, str(getattr(exc, "detail", exc)))


async def _robostar_error_response(request: Request, exc: Exception) -> Response:
    # a line down or too busy to take one more read: try again later (not a conflict)
    status = 503 if isinstance(exc, LineDownError | LineBusyError) else 409
    return _error(request, status, str(exc))


def _guard_error(status: int, message: str) -> Response:
    return JSONResponse({"ok": False, "error": message}, status_code=status)


def _error(request: Request, status: int, message: str) -> Response:
    if "text/html" in request.headers.get("accept", "") and request.method == "GET":
        return HTMLResponse(f"<h1>{status}</h1><p>{_escape(message)}</p>", status_code=status)
    return JSONResponse({"ok": False, "error": message}, status_code=status)


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
