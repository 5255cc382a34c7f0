"""The health page: each line's link, its errors and its last poll, and who holds its lease."""

from __future__ import annotations

from starlette.requests import Request
from starlette.responses import Response
from starlette.routing import BaseRoute, Route

from robostar.serve.faces.web.deps import deps_of
from robostar.serve.faces.web.views import health_row

__all__ = ["ROUTES"]


async def health(request: Request) -> Response:
    deps = deps_of(request)
    rows = [health_row(line) for line in deps.server.lines.values()]
    return deps.page(request, "health.html", health=rows)


ROUTES: list[BaseRoute] = [Route("/health", health)]
