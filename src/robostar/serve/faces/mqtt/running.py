"""A named MQTT command made ready against its line, and the lease's own commands run: shared
by the JSON tree and Sparkplug.

:mod:`commands` builds commands from parameters alone; a few need the line first: ``select_job``
by JOB number looks the number up in the channel's file listing (FD, read afresh: a number
names whichever file the controller holds under it now).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from robostar.commands.base import Command
from robostar.commands.files import ListFiles
from robostar.errors import UsageError
from robostar.serve.faces.mqtt.commands import lease_seconds, make_commands
from robostar.serve.lease import LeaseHeldError, Who

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["lease_request", "prepare_commands", "resolve_params"]


async def resolve_params(line: Line, name: str, params: Mapping[str, Any]) -> dict[str, Any]:
    """``params`` with what only the line can say filled in: ``select_job``'s ``number`` becomes
    the ``file`` FD lists under it. UsageError when the number names no JOB file."""
    out = dict(params)
    if name != "select_job" or "number" not in out:
        return out
    if "file" in out:
        raise UsageError('select_job: give "file" (a name) or "number" (a JOB number), not both')
    number = out.pop("number")
    if isinstance(number, bool) or not isinstance(number, int) or number < 1:
        raise UsageError(f"number: expected a JOB number (1 or more), not {number!r}")
    channel = out.get("channel")
    if isinstance(channel, bool) or not isinstance(channel, int):
        raise UsageError(f"channel: expected an integer, not {channel!r}")
    records = await line.read(ListFiles(channel), max_age=0)
    jobs = {r.job_number: r.name for r in records if r.name.upper().endswith(".JOB")}
    if number not in jobs:
        listed = ", ".join(f"{n} = {jobs[n]}" for n in sorted(jobs)) or "none"
        raise UsageError(
            f"no JOB file numbered {number} on channel {channel} (JOB files: {listed})"
        )
    out["file"] = jobs[number]
    return out


async def prepare_commands(
    line: Line, name: str, params: Mapping[str, Any]
) -> tuple[Command[Any], ...]:
    """The commands of ``name``, every field's range checked (UsageError or FieldError naming
    what is wrong) before anything that changes the robot is sent."""
    commands = make_commands(name, await resolve_params(line, name, params))
    for command in commands:
        command.encode()  # every field's range, as the wire would refuse it
    return commands


def lease_request(line: Line, who: Who, name: str, params: Mapping[str, Any]) -> dict[str, Any]:
    """``take_control`` or ``release_control`` for ``who``: the answer's body. The line audits
    the take, renewal, release or refusal; UsageError (a bad ``seconds``) before any of it."""
    if name == "release_control":
        return {"ok": True, "result": {"released": line.release_control(who)}}
    seconds = lease_seconds(params)
    try:
        info = line.take_control(who, seconds)
    except LeaseHeldError as exc:
        return {"ok": False, "error": str(exc), "kind": type(exc).__name__}
    until = round(info.expires_at, 3)
    return {"ok": True, "result": {"holder": who.name, "face": who.face, "until": until}}
