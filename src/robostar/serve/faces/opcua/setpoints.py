"""Writable setpoints: the variables an operator expects to write, through the line.

Every variable is read-only to clients but the setpoints listed here: today each channel's
``SpeedOverride`` (percent; the N1's CB speed, 0-1000, is the percentage times ten). A write to
one becomes a command on the line's queue, as the signed-in user through the ``opcua`` face,
under the line's lease and into the audit log, for operators on a signed channel only (as the
gated methods). The variable itself is not written: it shows the controller's value once the
line has read it back.

| outcome | the write's status code |
|---|---|
| done | ``Good`` |
| not an operator, an unsigned channel, or not a setpoint | ``BadUserAccessDenied`` |
| not a number | ``BadTypeMismatch`` |
| out of range (a speed is 0-100 %) | ``BadOutOfRange`` |
| another consumer holds the line's lease | ``BadLocked`` |
| the controller refused it | ``BadInvalidState`` |
| the line is down (nothing was sent) | ``BadNoCommunication`` |
| no answer: the outcome is unknown | ``BadTimeout`` |

asyncua's attribute service is replaced by one that sends clients' writes here; the server's
own writes (its internal session, an administrator) pass as before.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable
from typing import TYPE_CHECKING, Any

from asyncua import ua
from asyncua.crypto.permission_rules import User, UserRole
from asyncua.server.address_space import AttributeService

from robostar.commands.base import Command
from robostar.commands.control import SetSpeed
from robostar.errors import ControllerError, RobostarError, UsageError
from robostar.serve.faces.opcua._ua import AttributeIds, StatusCodes, status
from robostar.serve.faces.opcua.methods import status_for
from robostar.serve.faces.opcua.security import current_caller
from robostar.serve.lease import Who

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["SetpointAttributeService", "Setter", "speed_setter"]

log = logging.getLogger("robostar.serve.opcua")

Setter = Callable[[ua.DataValue], Awaitable[ua.StatusCode]]
_SERVER = User(role=UserRole.Admin)
"""asyncua's default writer: its internal session."""


def _code(name: str) -> ua.StatusCode:
    return status(getattr(StatusCodes, name))


class SetpointAttributeService(AttributeService):
    """asyncua's attribute service, with clients' writes going to the setpoints' setters."""

    def __init__(self, aspace: Any) -> None:
        super().__init__(aspace)
        self.setters: dict[ua.NodeId, Setter] = {}

    async def write(self, params: ua.WriteParameters, user: User = _SERVER) -> list[ua.StatusCode]:
        if user.role == UserRole.Admin:  # the server's own session (clients never are)
            return await super().write(params, user)
        results = []
        for value in params.NodesToWrite:
            setter = self.setters.get(value.NodeId)
            if setter is None or value.AttributeId != AttributeIds.Value:
                results.append(_code("BadUserAccessDenied"))
            else:
                results.append(await setter(value.Value))
        return results


def speed_setter(line: Line, channel: int) -> Setter:
    """``SpeedOverride`` of ``channel``: a percentage, sent as CB (tenths of a percent)."""

    def command(percent: float) -> Command[Any]:
        return SetSpeed(channel, round(percent * 10))

    return _setter(line, f"SpeedOverride(channel={channel})", command, 0.0, 100.0)


def _setter(
    line: Line,
    what: str,
    command_for: Callable[[float], Command[Any]],
    low: float,
    high: float,
) -> Setter:
    async def write(data: ua.DataValue) -> ua.StatusCode:
        caller = current_caller()
        who = Who(caller.name if caller is not None and caller.name else "anonymous", "opcua")
        if caller is None or not caller.may_operate():
            unsigned = caller is not None and not caller.secure
            line.record(
                what, who, f"refused: {'an unsigned channel' if unsigned else 'not an operator'}"
            )
            return _code("BadUserAccessDenied")
        value = data.Value.Value if data.Value is not None else None
        if isinstance(value, bool) or not isinstance(value, int | float):
            line.record(what, who, f"refused: {value!r} is not a number")
            return _code("BadTypeMismatch")
        if not low <= value <= high:
            line.record(what, who, f"refused: {value} is not {low:g}-{high:g}")
            return _code("BadOutOfRange")
        command = command_for(float(value))
        try:
            command.encode()  # its form, before anything waits for the line
        except UsageError as exc:
            line.record(what, who, f"refused: {exc}")
            return _code("BadOutOfRange")
        try:
            await line.execute(command, who=who, implicit_lease=True)
        except ControllerError as exc:
            log.info("opcua %s: %s by %s refused: %s", line.name, what, who.name, exc)
            return _code("BadInvalidState")
        except RobostarError as exc:
            log.info("opcua %s: %s by %s failed: %s", line.name, what, who.name, exc)
            return status_for(exc)
        return _code("Good")

    return write
