"""The variables page of one line: a page of global variables read fresh, and one written
(GW, confirmed, by an engineer)."""

from __future__ import annotations

from starlette.requests import Request
from starlette.responses import RedirectResponse, Response
from starlette.routing import BaseRoute, Route

from robostar.errors import UsageError
from robostar.serve.faces.web.auth import read_form
from robostar.serve.faces.web.deps import Forbidden, deps_of
from robostar.serve.faces.web.forms import int_field
from robostar.serve.faces.web.variables import KINDS, PAGE_MAX, build_write, page_range, read_rows
from robostar.serve.users import Role

__all__ = ["ROUTES"]


async def variables(request: Request) -> Response:
    """Global variables of one kind, a page of indexes read fresh from the controller."""
    deps = deps_of(request)
    line = deps.line_of(request)
    query = request.query_params
    kind = query.get("kind", "int")
    if kind not in KINDS:
        raise Forbidden(400, f"kind: one of {', '.join(KINDS)}")
    channel = int_field(query.get("channel", "1"), "channel", 1, 3)
    start = int_field(query.get("start", "0"), "start", 0, 1023)
    count = int_field(query.get("count", "20"), "count", 1, PAGE_MAX)
    try:
        indexes = page_range(kind, start, count)
    except UsageError as exc:
        raise Forbidden(400, str(exc)) from None
    rows = await read_rows(line, kind, channel, indexes)
    return deps.page(
        request,
        "variables.html",
        line=line,
        kind=kind,
        kinds=KINDS,
        channel=channel,
        start=start,
        count=count,
        rows=rows,
        saved=query.get("saved"),
    )


async def variable_write(request: Request) -> Response:
    """GW of one integer or float, confirmed, by an engineer, under the lease and audited."""
    deps = deps_of(request)
    line = deps.line_of(request)
    account = await deps.guard(request, Role.ENGINEER, line, "variable write")
    form = await read_form(request)
    if form.get("confirmed") != "yes":
        raise Forbidden(428, "confirm the new value first")
    kind = str(form.get("kind", ""))
    index = int_field(form.get("index"), "index", 0, 499)
    try:
        command = build_write(kind, index, str(form.get("value", "")))
        command.encode()  # the field's own checks, before the queue
    except UsageError as exc:
        raise Forbidden(400, str(exc)) from None
    await deps.run(line, command, account)
    start = int_field(form.get("start", str(index)), "start", 0, 1023)
    return RedirectResponse(
        f"/line/{line.name}/variables?kind={kind}&start={start}&saved={index}",
        status_code=303,
    )


ROUTES: list[BaseRoute] = [
    Route("/line/{line}/variables", variables, methods=["GET"]),
    Route("/line/{line}/variables", variable_write, methods=["POST"]),
]
