"""Who has control: every page shows each line's lease (who holds it, until when), an operator
takes a free one for a sequence of commands, and its holder gives it back. A one-shot command
from the dashboard takes a free lease for itself (the line's implicit lease); holding control
across several is this explicit take."""

from __future__ import annotations

import time
from typing import Any

from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import BaseRoute, Route

from robostar.errors import RobostarError
from robostar.serve.faces.web.auth import Account
from robostar.serve.faces.web.deps import Forbidden, deps_of
from robostar.serve.lease import Who
from robostar.serve.line import Line
from robostar.serve.users import Role

__all__ = ["ROUTES", "TAKE_SECONDS", "lease_row"]

TAKE_SECONDS = 300.0
"""How long an explicit take holds the lease unless renewed by the holder's commands."""


def lease_row(line: Line, account: Account) -> dict[str, Any]:
    """A line's lease as the page shows it, and what ``account`` may do with it."""
    holder = line.lease.holder
    mine = holder is not None and holder.who == Who(account.name, "web") and account.user
    return {
        "line": line.name,
        "free": holder is None,
        "holder": None if holder is None else str(holder.who),
        "until": None if holder is None else holder.expires_at,
        "left": None if holder is None else max(0, round(holder.expires_at - time.time())),
        "mine": bool(mine),
        "may_take": holder is None and account.may(Role.OPERATOR),
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
    who = Who(account.name, "web")
    holder = line.lease.holder
    if holder is not None and holder.who != who:
        line.record("lease take", who, f"refused: held by {holder.who}")
        raise Forbidden(409, f"line {line.name}: control is held by {holder.who}")
    try:
        line.lease.acquire(who, TAKE_SECONDS)
    except RobostarError as exc:
        line.record("lease take", who, f"refused: {exc}")
        raise
    line.record(f"lease take for {TAKE_SECONDS:.0f} s", who, "ok")
    return JSONResponse({"ok": True, "lease": lease_row(line, account)})


ROUTES: list[BaseRoute] = [
    Route("/leases", leases),
    Route("/line/{line}/lease/take", take, methods=["POST"]),
]
