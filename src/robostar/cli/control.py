"""Controller-wide and channel control: servo, speed, estop, reset, restart, ref-axis."""

from __future__ import annotations

import click
from rich.text import Text

from robostar.cli.options import ON_OFF, common_options, get_session
from robostar.cli.session import ConsoleSession, pass_session
from robostar.commands.control import (
    EmergencyStop,
    ReadReferenceAxis,
    ReadSpeed,
    ResetAlarms,
    Restart,
    SetReferenceAxis,
    SetSpeed,
)
from robostar.commands.job import Servo

__all__ = ["done", "estop", "ref_axis", "reset", "restart", "servo", "speed"]


def done(session: ConsoleSession, message: str, **data: object) -> None:
    """Report an action that went through."""
    session.out.result({"ok": True, **data}, Text(message, style="green"))


@click.command()
@click.argument("state", type=ON_OFF)
@common_options(channel=True)
@pass_session
def servo(session: ConsoleSession, state: str) -> None:
    """Turn a channel's servo on or off (DB); waits until the controller says it is done.

    \b
    Example:
      robostar servo on
      robostar --channel 2 servo off
    """
    on = state.lower() == "on"
    wait = session.send(Servo(session.channel, on))
    done(
        session,
        f"Channel {session.channel} servo is {'on' if on else 'off'}.",
        channel=session.channel,
        servo_on=on,
        expected_wait_s=wait,
    )


@click.group(invoke_without_command=True)
@common_options(channel=True)
@click.pass_context
def speed(ctx: click.Context) -> None:
    """Show a channel's speed (0-1000, where 1000 is 100 % of Mv); `speed set` changes it.

    \b
    Example:
      robostar speed
      robostar speed set 300
    """
    if ctx.invoked_subcommand is not None:
        return
    session = get_session(ctx)
    value = session.send(ReadSpeed(session.channel))
    session.out.result(
        {"channel": session.channel, "speed": value, "percent": value / 10},
        Text(f"Channel {session.channel} speed: {value} ({value / 10:g} % of Mv)"),
    )


@speed.command("set")
@click.argument("value", type=click.IntRange(0, 1000))
@common_options(channel=True)
@pass_session
def speed_set(session: ConsoleSession, value: int) -> None:
    """Set a channel's speed, 0-1000 (1000 is 100 % of each axis's Mv).

    \b
    Example:
      robostar speed set 250
    """
    session.send(SetSpeed(session.channel, value))
    done(
        session,
        f"Channel {session.channel} speed set to {value} ({value / 10:g} % of Mv).",
        channel=session.channel,
        speed=value,
    )


@click.command()
@common_options()
@pass_session
def estop(session: ConsoleSession) -> None:
    """Emergency stop (CF): stops every channel and raises the Host Emergency alarm.

    Clear it afterwards with `robostar reset`.

    \b
    Example:
      robostar estop
    """
    session.send(EmergencyStop())
    done(session, "Emergency stop sent. Clear the alarm with `robostar reset`.", estop=True)


@click.command()
@common_options()
@pass_session
def reset(session: ConsoleSession) -> None:
    """Reset the controller's alarms (CG).

    \b
    Example:
      robostar reset
    """
    session.send(ResetAlarms())
    done(session, "Alarms reset.", reset=True)


@click.command()
@common_options()
@pass_session
def restart(session: ConsoleSession) -> None:
    """Restart the controller (CJ), for an alarm reset cannot clear; the servo must be off.

    \b
    Example:
      robostar servo off && robostar restart
    """
    session.send(Restart())
    done(session, "The controller is restarting.", restart=True)


@click.command("ref-axis")
@click.argument("axis", type=click.Choice(["1", "4"]), required=False)
@common_options(channel=True)
@pass_session
def ref_axis(session: ConsoleSession, axis: str | None) -> None:
    """Show or set the reference axis of interpolated moves: 1 (X) or 4 (W).

    Setting it needs the servo off.

    \b
    Example:
      robostar ref-axis
      robostar ref-axis 4
    """
    if axis is None:
        value = session.send(ReadReferenceAxis(session.channel))
        name = "X" if value == 1 else "W"
        session.out.result(
            {"channel": session.channel, "reference_axis": value},
            Text(f"Channel {session.channel} reference axis: {value} ({name})"),
        )
        return
    session.send(SetReferenceAxis(session.channel, int(axis)))
    done(
        session,
        f"Channel {session.channel} reference axis set to {axis}.",
        channel=session.channel,
        reference_axis=int(axis),
    )
