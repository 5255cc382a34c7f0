"""The controller page of one line: lamps, positions, I/O, alarms, and the operator's actions
(servo, job start and stop, speed, outputs, alarm reset, emergency stop) and the lease release."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import BaseRoute, Route

from robostar.commands.base import Command
from robostar.commands.control import EmergencyStop, ResetAlarms, SetSpeed, StartJob, StopJob
from robostar.commands.io import SetOutput
from robostar.commands.job import Servo
from robostar.serve.faces.web.deps import Forbidden, deps_of, needs
from robostar.serve.faces.web.forms import int_field, json_body
from robostar.serve.faces.web.views import card, detail
from robostar.serve.jsonable import jsonable
from robostar.serve.lease import Who
from robostar.serve.users import Role

__all__ = ["ACTIONS", "ROUTES"]


async def controller(request: Request) -> Response:
    deps = deps_of(request)
    line = deps.line_of(request)
    return deps.page(request, "controller.html", line=line, card=card(line), detail=detail(line))


@dataclass(frozen=True, slots=True)
class Action:
    role: Role
    build: Callable[[dict[str, Any]], Command[Any]]


def _channel(body: dict[str, Any]) -> int:
    return int_field(body.get("channel"), "channel", 1, 3)


def _on(body: dict[str, Any]) -> bool:
    value = body.get("on")
    if not isinstance(value, bool):
        raise Forbidden(400, "on: true or false")
    return value


ACTIONS: dict[str, Action] = {
    "servo": Action(Role.OPERATOR, lambda b: Servo(_channel(b), _on(b))),
    "job_start": Action(Role.OPERATOR, lambda b: StartJob(_channel(b))),
    "job_stop": Action(Role.OPERATOR, lambda b: StopJob(_channel(b))),
    "reset_alarms": Action(Role.OPERATOR, lambda b: ResetAlarms()),
    "emergency_stop": Action(Role.OPERATOR, lambda b: EmergencyStop()),
    "speed": Action(
        Role.OPERATOR, lambda b: SetSpeed(_channel(b), int_field(b.get("speed"), "speed", 0, 1000))
    ),
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
    command = spec.build(body)
    result = await deps.run(line, command, account)
    return JSONResponse({"ok": True, "action": name, "result": jsonable(result)})


async def release(request: Request) -> Response:
    """Give the controller's lease back (only its holder can)."""
    deps = deps_of(request)
    line = deps.line_of(request)
    account = await deps.guard(request, Role.OPERATOR, line, "lease release")
    who = Who(account.name, "web")
    released = line.lease.release(who)
    # a change of who has control is part of the record, as the writes made under it are
    line.record("lease release", who, "ok" if released else "not held: nothing released")
    return JSONResponse({"ok": True, "released": released})


ROUTES: list[BaseRoute] = [
    Route("/line/{line}", controller),
    Route("/line/{line}/action", action, methods=["POST"]),
    Route("/line/{line}/release", release, methods=["POST"]),
]
