"""Who has control: every page shows each line's lease (who holds it, until when), an operator
takes a free one for a sequence of commands, and its holder gives it back. A click takes a free
lease for its one command and the line gives it back as the command ends (a one-shot lease,
shown while it lasts); holding control across several commands is this explicit take. Both go
through the line's own calls (``Line.control``, ``take_control``, ``release_control``), which
write the one audit entry of each."""

from __future__ import annotations

from typing import Any

from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import BaseRoute, Route

from robostar.serve.faces.web.auth import Account
from robostar.serve.faces.web.deps import Forbidden, deps_of
from robostar.serve.lease import LeaseHeldError, Who
from robostar.serve.line import Line
from robostar.serve.users import Role

__all__ = ["ROUTES", "TAKE_SECONDS", "lease_row"]

TAKE_SECONDS = 300.0
"""How long an explicit take holds the lease unless renewed by the holder's commands."""


def lease_row(line: Line, account: Account) -> dict[str, Any]:
    """A line's lease as the page shows it, and what ``account`` may do with it."""
    state = line.control()
    holder = None if state.free else f"{state.holder} ({state.face})"
    mine = holder is not None and holder == str(Who(account.name, "web")) and account.user
    return {
        "line": line.name,
        "free": state.free,
        "holder": holder,
        "until": state.until,
        "left": None if state.left is None else max(0, round(state.left)),
        "once": state.once,
        "mine": bool(mine) and not state.once,
        "may_take": state.free and account.may(Role.OPERATOR),
    }


async def leases(request: Request) -> Response:
    deps = deps_of(request)
    account = deps.account(request)
    rows = [lease_row(line, account) for line in deps.server.lines.values()]
    return JSONResponse({"leases": rows})


async def take(request: Request) -> Response:
    """Take a free lease for :data:`TAKE_SECONDS` (an operator); renewed by the holder's writes."""
    deps = deps_of(request)
    line = deps.line_of(request)
    account = await deps.guard(request, Role.OPERATOR, line, "lease take")
    try:
        line.take_control(Who(account.name, "web"), TAKE_SECONDS)  # audited by the line
    except LeaseHeldError as exc:
        raise Forbidden(409, str(exc)) from exc
    return JSONResponse({"ok": True, "lease": lease_row(line, account)})


async def release(request: Request) -> Response:
    """Give the line's lease back (only its holder can); audited by the line."""
    deps = deps_of(request)
    line = deps.line_of(request)
    account = await deps.guard(request, Role.OPERATOR, line, "lease release")
    released = line.release_control(Who(account.name, "web"))
    return JSONResponse({"ok": True, "released": released})


ROUTES: list[BaseRoute] = [
    Route("/leases", leases),
    Route("/line/{line}/lease/take", take, methods=["POST"]),
    Route("/line/{line}/lease/release", release, methods=["POST"]),
    Route("/line/{line}/release", release, methods=["POST"]),  # the older address
]
