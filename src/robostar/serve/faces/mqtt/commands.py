"""Write-back over MQTT (off by default): a command message becomes a robostar command.

A message on ``<prefix>/<line>/cmd/<name>`` holds JSON parameters. Only the names in the
configuration's allowlist are taken; the parameters are checked (types, then the command's own
range checks, by encoding it) before anything reaches the line. The result goes to the MQTT 5
response topic with the request's correlation data, or to ``.../cmd/<name>/result`` with the
payload's ``"id"``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from typing import Any

from robostar.commands.base import Command
from robostar.commands.control import EmergencyStop, ResetAlarms, SetSpeed, StartJob, StopJob
from robostar.commands.io import SetOutput
from robostar.commands.job import SelectJob, Servo, SetJobMode
from robostar.commands.motion import Home
from robostar.commands.variables import WriteGlobalFloat, WriteGlobalInt
from robostar.errors import UsageError
from robostar.types import JobMode

__all__ = [
    "COMMANDS",
    "ESTOP",
    "LEASE_COMMANDS",
    "NAMES",
    "build_command",
    "build_commands",
    "lease_seconds",
    "make_command",
    "make_commands",
    "read_params",
]

ESTOP = "estop"


def _int(params: Mapping[str, Any], name: str) -> int:
    value = params.get(name)
    if isinstance(value, bool) or not isinstance(value, int):
        raise UsageError(f"{name}: expected an integer, not {value!r}")
    return value


def _float(params: Mapping[str, Any], name: str) -> float:
    value = params.get(name)
    if isinstance(value, bool) or not isinstance(value, int | float) or value != value:
        raise UsageError(f"{name}: expected a number, not {value!r}")
    return float(value)


def _text(params: Mapping[str, Any], name: str) -> str:
    value = params.get(name)
    if not isinstance(value, str) or not value:
        raise UsageError(f'{name}: expected a name such as "MAIN.JOB", not {value!r}')
    return value


def _job_file(params: Mapping[str, Any]) -> str:
    value = params.get("file")
    if isinstance(value, int) and not isinstance(value, bool):
        raise UsageError(
            f'file: expected a name such as "MAIN.JOB", not {value!r} (a JOB number goes as'
            f' "number": {value})'
        )
    return _text(params, "file")


def _mode(params: Mapping[str, Any]) -> JobMode:
    value = params.get("mode")
    if value not in ("auto", "step"):
        raise UsageError(f'mode: expected "auto" or "step", not {value!r}')
    return JobMode.STEP if value == "step" else JobMode.AUTO


def _bool(params: Mapping[str, Any], name: str) -> bool:
    value = params.get(name)
    if not isinstance(value, bool):
        raise UsageError(f"{name}: expected true or false, not {value!r}")
    return value


COMMANDS: dict[str, Callable[[Mapping[str, Any]], tuple[Command[Any], ...]]] = {
    "servo": lambda p: (Servo(_int(p, "channel"), _bool(p, "on")),),
    "home": lambda p: (Home(_int(p, "channel")),),
    # by name; by JOB number ("number") once running.resolve_params has found its name
    "select_job": lambda p: (SelectJob(_int(p, "channel"), _job_file(p)),),
    "job_mode": lambda p: (SetJobMode(_int(p, "channel"), _mode(p)),),
    "start_job": lambda p: (StartJob(_int(p, "channel")),),
    # One step of the selected job: step mode, then start (the controller runs one step).
    "step_job": lambda p: (
        SetJobMode(_int(p, "channel"), JobMode.STEP),
        StartJob(_int(p, "channel")),
    ),
    "stop_job": lambda p: (StopJob(_int(p, "channel")),),
    "reset_alarms": lambda p: (ResetAlarms(),),
    "speed": lambda p: (SetSpeed(_int(p, "channel"), _int(p, "value")),),
    "output": lambda p: (SetOutput(_int(p, "port"), _int(p, "contact"), _bool(p, "on")),),
    "global_int": lambda p: (WriteGlobalInt(_int(p, "index"), _int(p, "value")),),
    "global_float": lambda p: (WriteGlobalFloat(_int(p, "index"), _float(p, "value")),),
    ESTOP: lambda p: (EmergencyStop(),),
}
"""Every command the face can take, by topic name (the allowlist picks among them): each is
the robostar commands it runs, in order (``step_job`` is two)."""


LEASE_COMMANDS = frozenset(("take_control", "release_control"))
"""Commands on the line's lease rather than the robot: ``take_control`` holds it for a sequence
of commands (``seconds``, else the line's ``lease_ttl``, renewed by each command), and
``release_control`` gives it back. A single command takes a free lease for itself only."""
NAMES = frozenset(COMMANDS) | LEASE_COMMANDS
"""Every name the allowlist may hold."""
MAX_LEASE_SECONDS = 3600.0
"""The longest ``take_control`` (as the HTTP API's ``?ttl=``)."""


def lease_seconds(params: Mapping[str, Any]) -> float | None:
    """``take_control``'s ``seconds`` (None: the line's ``lease_ttl``); UsageError when it is no
    number, or not more than 0 and at most an hour."""
    if params.get("seconds") is None:
        return None
    seconds = _float(params, "seconds")
    if not 0 < seconds <= MAX_LEASE_SECONDS:
        raise UsageError(f"seconds: more than 0 and at most {MAX_LEASE_SECONDS:g}, not {seconds:g}")
    return seconds


def read_params(payload: bytes) -> dict[str, Any]:
    """The message's JSON object; UsageError ("bad payload: ...") for anything else, whatever
    the bytes are (nesting too deep for the parser included). The caller caps the size.

    An empty payload is refused, not read as ``{}``: an empty retained publish is how MQTT
    clears a retained message, so clearing a retained ``cmd/estop`` must not run an E-stop."""
    if not payload:
        raise UsageError("bad payload: empty (send a JSON object, {} for no parameters)")
    try:
        params = json.loads(payload)
    except (ValueError, UnicodeDecodeError) as exc:
        raise UsageError(f"bad payload: not JSON ({exc})") from None
    except RecursionError:
        raise UsageError("bad payload: JSON nested too deeply") from None
    if not isinstance(params, dict):
        raise UsageError("bad payload: not a JSON object")
    return params


def make_commands(name: str, params: Mapping[str, Any]) -> tuple[Command[Any], ...]:
    """The commands, their parameters' types checked (UsageError), their ranges not yet."""
    make = COMMANDS.get(name)
    if make is None:
        raise UsageError(f"unknown command {name!r} (commands: {', '.join(sorted(NAMES))})")
    return make(params)


def make_command(name: str, params: Mapping[str, Any]) -> Command[Any]:
    """The last (for all but ``step_job`` the only) command of :func:`make_commands`."""
    return make_commands(name, params)[-1]


def build_commands(name: str, params: Mapping[str, Any]) -> tuple[Command[Any], ...]:
    """The commands; UsageError (or FieldError) naming what is wrong, before anything is sent."""
    commands = make_commands(name, params)
    for command in commands:
        command.encode()  # every field's range, as the wire would refuse it
    return commands


def build_command(name: str, params: Mapping[str, Any]) -> Command[Any]:
    return build_commands(name, params)[-1]
