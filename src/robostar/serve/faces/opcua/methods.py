"""The methods a client may call, and what each becomes on the line.

| method | where | command |
|---|---|---|
| ``Start`` | TaskControlStateMachine of a channel | CC (start the selected job) |
| ``Stop`` | same | CD (stop the job) |
| ``LoadByName(Name)`` | same | DC (select the JOB file) |
| ``EmergencyStop`` | the controller's Robostar folder (vendor) | CF |

Each goes through the line's queue, lease and audit log, as ``Who(user, "opcua")``, and only
for a signed-in user with the operator role on a signed channel.

Where the controller (or the face, for it) says no, the call succeeds and its output argument
``Status`` says why, with the codes the Robotics nodeset gives ``LoadByName`` (0 OK,
1 E_SystemState, 3 E_ActiveAlarm). ``Start``, ``Stop`` and the vendor ``EmergencyStop`` leave
codes above 0 to future standards and below 0 to vendors, so they say the same with the sign
turned: -1 refused by the controller, -3 an alarm is active.

| outcome | ``LoadByName`` | ``Start``, ``Stop``, ``EmergencyStop`` |
|---|---|---|
| done | Good, Status 0 | Good, Status 0 |
| an alarm is active (nothing is sent) | Good, Status 3 | Good, Status -3 (Start) |
| the controller refused (an error answer) | Good, Status 1 | Good, Status -1 |

Where the call cannot be made at all, the call's own status code says so:

| outcome | status code |
|---|---|
| not signed in, not an operator, or an unsigned channel | ``BadUserAccessDenied`` |
| another consumer holds the line's lease | ``BadLocked`` |
| a bad argument (a file name the N1 cannot take) | ``BadInvalidArgument`` |
| the line is down (nothing was sent) | ``BadNoCommunication`` |
| no answer: the outcome is unknown | ``BadTimeout`` |
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable
from typing import TYPE_CHECKING, Any

from asyncua import ua

from robostar.commands.base import Command
from robostar.commands.control import EmergencyStop, StartJob, StopJob
from robostar.commands.job import SelectJob
from robostar.errors import (
    ControllerError,
    LineError,
    OutcomeUnknownError,
    ReplyTimeoutError,
    RobostarError,
    UsageError,
)
from robostar.serve.faces.opcua._ua import StatusCodes, status
from robostar.serve.faces.opcua.security import current_caller
from robostar.serve.lease import LeaseHeldError, Who

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["Handler", "handler_for"]

log = logging.getLogger("robostar.serve.opcua")

Handler = Callable[..., Awaitable[Any]]


def _code(name: str) -> ua.StatusCode:
    return status(getattr(StatusCodes, name))


E_SYSTEM_STATE = 1
"""The Robotics nodeset's LoadByName Status: the system is not in a state for this."""
E_ACTIVE_ALARM = 3
"""The Robotics nodeset's LoadByName Status: an active alarm prevents it."""


def _status(method: str, code: int) -> list[ua.Variant]:
    """The output argument Status: LoadByName's own codes, the vendor's (negative) for the
    methods whose positive codes are reserved."""
    value = code if method == "LoadByName" or code == 0 else -code
    return [ua.Variant(value, ua.VariantType.Int32)]


def status_for(exc: RobostarError) -> ua.StatusCode:
    """The status code of a call that could not be made (see the module's second table)."""
    if isinstance(exc, LeaseHeldError):
        return _code("BadLocked")
    if isinstance(exc, OutcomeUnknownError | ReplyTimeoutError):
        return _code("BadTimeout")
    if isinstance(exc, UsageError):
        return _code("BadInvalidArgument")
    if isinstance(exc, LineError):
        return _code("BadNoCommunication")
    return _code("BadUnexpectedError")


def _alarm_active(line: Line, channel: int | None) -> bool:
    alarms = line.model.get("alarms")
    if alarms is not None and alarms.value:
        return True
    if channel is not None:
        status = line.model.get(f"ch{channel}/status")
        if status is not None and getattr(status.value, "alarm", False):
            return True
    return False


def handler_for(line: Line, method: str, channel: int | None) -> Handler:
    """The coroutine asyncua calls for ``method`` (of ``channel``'s task control, or the
    controller's EmergencyStop when ``channel`` is None)."""

    async def handle(parent: ua.NodeId, *args: ua.Variant) -> Any:
        caller = current_caller()
        name = caller.name if caller is not None and caller.name else "anonymous"
        who = Who(name, "opcua")
        try:
            command = _command(method, channel, args)
        except RobostarError as exc:
            line.record(method, who, f"refused: {exc}")
            return status_for(exc)
        if caller is None or not caller.may_operate():
            unsigned = caller is not None and not caller.secure
            line.record(
                command, who, f"refused: {'an unsigned channel' if unsigned else 'not an operator'}"
            )
            return _code("BadUserAccessDenied")
        if isinstance(command, StartJob | SelectJob) and _alarm_active(line, channel):
            line.record(command, who, "refused: an alarm is active")
            return _status(method, E_ACTIVE_ALARM)
        try:
            await line.execute(command, who=who, implicit_lease=True)
        except ControllerError as exc:
            log.info("opcua %s: %s by %s refused: %s", line.name, method, who.name, exc)
            return _status(method, E_SYSTEM_STATE)
        except RobostarError as exc:
            log.info("opcua %s: %s by %s failed: %s", line.name, method, who.name, exc)
            return status_for(exc)
        return _status(method, 0)

    return handle


def _command(method: str, channel: int | None, args: tuple[ua.Variant, ...]) -> Command[Any]:
    values = [a.Value if isinstance(a, ua.Variant) else a for a in args]
    if method == "EmergencyStop":
        return EmergencyStop()
    assert channel is not None
    if method == "Start":
        return StartJob(channel)
    if method == "Stop":
        return StopJob(channel)
    if method == "LoadByName":
        if len(values) != 1 or not isinstance(values[0], str):
            raise UsageError("LoadByName takes one String argument, the JOB file's name")
        command = SelectJob(channel, values[0])
        command.encode()  # the name's form, before anything waits for the line
        return command
    raise UsageError(f"unknown method {method!r}")
