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
from robostar.commands.control import EmergencyStop, SetSpeed, StartJob, StopJob
from robostar.commands.io import SetOutput
from robostar.commands.job import Servo
from robostar.commands.variables import WriteGlobalFloat, WriteGlobalInt
from robostar.errors import UsageError

__all__ = ["COMMANDS", "ESTOP", "build_command", "make_command", "read_params"]

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


def _bool(params: Mapping[str, Any], name: str) -> bool:
    value = params.get(name)
    if not isinstance(value, bool):
        raise UsageError(f"{name}: expected true or false, not {value!r}")
    return value


COMMANDS: dict[str, Callable[[Mapping[str, Any]], Command[Any]]] = {
    "servo": lambda p: Servo(_int(p, "channel"), _bool(p, "on")),
    "start_job": lambda p: StartJob(_int(p, "channel")),
    "stop_job": lambda p: StopJob(_int(p, "channel")),
    "speed": lambda p: SetSpeed(_int(p, "channel"), _int(p, "value")),
    "output": lambda p: SetOutput(_int(p, "port"), _int(p, "contact"), _bool(p, "on")),
    "global_int": lambda p: WriteGlobalInt(_int(p, "index"), _int(p, "value")),
    "global_float": lambda p: WriteGlobalFloat(_int(p, "index"), _float(p, "value")),
    ESTOP: lambda p: EmergencyStop(),
}
"""Every command the face can take, by topic name (the allowlist picks among them)."""


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


def make_command(name: str, params: Mapping[str, Any]) -> Command[Any]:
    """The command, its parameters' types checked (UsageError), their ranges not yet."""
    make = COMMANDS.get(name)
    if make is None:
        raise UsageError(f"unknown command {name!r} (commands: {', '.join(COMMANDS)})")
    return make(params)


def build_command(name: str, params: Mapping[str, Any]) -> Command[Any]:
    """The command; UsageError (or FieldError) naming what is wrong, before anything is sent."""
    command = make_command(name, params)
    command.encode()  # every field's range, as the wire would refuse it
    return command
