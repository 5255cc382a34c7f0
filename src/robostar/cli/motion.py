"""Commands that move the robot: home, move, move-point. Each says so before it moves."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import click
from rich.console import Group
from rich.text import Text

from robostar.cli.options import ControllerFile, Finite, common_options
from robostar.cli.reading import position_json, position_view
from robostar.cli.session import ConsoleSession, pass_session
from robostar.commands.control import StopHoming
from robostar.commands.motion import Home, Move, MoveBy, MoveToPoint
from robostar.commands.status import ReadPosition
from robostar.errors import UsageError
from robostar.types import CoordSystem, MotionType, PositionKind

__all__ = ["finish_motion", "home", "move", "move_point", "parse_point"]

F = TypeVar("F", bound=Callable[..., Any])

_MOTIONS = {
    "joint": MotionType.JOINT,
    "linear": MotionType.LINEAR,
    "arc": MotionType.ARC,
    "circle": MotionType.CIRCLE,
}


def parse_point(text: str, what: str) -> tuple[float, ...]:
    """``"100,-20.5,0,0"`` as axis values (1-6 of them)."""
    parts = [p for p in text.replace(" ", ",").split(",") if p]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise UsageError(f"{what}: {text!r} is not a list of numbers like 100,-20.5,0") from None
    if not 1 <= len(values) <= 6:
        raise UsageError(f"{what}: give 1 to 6 axis values, not {len(values)}")
    return values


def _motion_options(func: F) -> F:
    helps = {
        "circle": "A circle through the --via point and the target (CMOV).",
        "arc": "An arc through the --via point to the target (AMOV).",
        "linear": "A straight line (LMOV).",
        "joint": "Joint interpolation, all axes arrive together (JMOV; the default).",
    }
    for flag, text in helps.items():
        extra: dict[str, Any] = {"default": True} if flag == "joint" else {}
        func = click.option(f"--{flag}", "motion", flag_value=flag, help=text, **extra)(func)
    return _wait_options(func)


def _wait_options(func: F) -> F:
    func = click.option(
        "--wait-timeout",
        type=Finite(min=0.1),
        default=120.0,
        show_default=True,
        metavar="SECONDS",
        help="How long to wait for the robot to stop.",
    )(func)
    return click.option(
        "--wait/--no-wait",
        default=True,
        show_default=True,
        help="Wait until the robot stops, then show where it is.",
    )(func)


def finish_motion(
    session: ConsoleSession, wait: bool, timeout: float, summary: dict[str, Any]
) -> None:
    """Wait for the channel to stop (when asked) and report the position it reached."""
    channel = session.channel
    if not wait:
        session.out.result(
            {"ok": True, "waited": False, **summary}, Text("Motion started.", style="green")
        )
        return
    session.client.wait_stopped(channel, timeout)
    pos = session.send(ReadPosition(channel, PositionKind.XY))
    session.out.result(
        {"ok": True, "waited": True, **summary, "position": position_json(channel, pos)},
        lambda: Group(Text("Motion done.", style="green"), position_view(channel, pos)),
    )


@click.command()
@click.option("--stop", is_flag=True, help="Stop a homing in progress (CI) instead.")
@_wait_options
@common_options(channel=True)
@pass_session
def home(session: ConsoleSession, stop: bool, wait: bool, wait_timeout: float) -> None:
    """Return a channel's robot to its origin (BA), and wait until the origin is set.

    \b
    Example:
      robostar home
      robostar home --stop
    """
    channel = session.channel
    if stop:
        session.send(StopHoming(channel))
        session.out.result(
            {"ok": True, "channel": channel, "homing": "stopped"},
            Text(f"Homing stopped on channel {channel}.", style="green"),
        )
        return
    command = Home(channel)
    session.announce(f"Channel {channel} is homing: the robot moves to its origin.")
    session.send(command)
    if wait:
        session.client.wait_homed(channel, wait_timeout)
    finish_motion(session, wait, wait_timeout, {"channel": channel, "homed": wait})


@click.command(context_settings={"ignore_unknown_options": True})
@click.argument("coordinates", nargs=-1, required=True)
@click.option("--by", "relative", is_flag=True, help="Move BY these amounts (BD), not TO them.")
@click.option("--xy", is_flag=True, help="Coordinates are XY (mm) rather than joint angles.")
@click.option(
    "--via",
    metavar="A,B,C,...",
    default=None,
    help="The via point for --arc and --circle, comma-separated like the target.",
)
@_motion_options
@common_options(channel=True)
@pass_session
def move(
    session: ConsoleSession,
    coordinates: tuple[str, ...],
    relative: bool,
    xy: bool,
    via: str | None,
    motion: str,
    wait: bool,
    wait_timeout: float,
) -> None:
    """Move a channel to COORDINATES (one value per axis), or by them with --by.

    Joint angles (degrees, mm on a linear axis) by default; --xy for XY. --arc moves along an
    arc through --via to the target; --circle runs a circle through --via and the target. Negative
    values may be given as they are (-20).

    \b
    Example:
      robostar move 10 20 50 0
      robostar move --xy --linear 300 100 50 0
      robostar move --by -5 0 0 0
      robostar move --arc --xy --via 250,50,50,0 300,100,50,0
    """
    for value in coordinates:
        if value.startswith("--"):
            raise UsageError(f"no such option: {value}")
    target = parse_point(",".join(coordinates), "coordinates")
    kind = _MOTIONS[motion]
    coords = CoordSystem.XY if xy else CoordSystem.ANGLE
    channel = session.channel
    if relative:
        if kind not in (MotionType.JOINT, MotionType.LINEAR):
            raise UsageError("--by moves with --joint or --linear only, not along an arc")
        if via is not None:
            raise UsageError("--via is for --arc and --circle moves")
        command: Move | MoveBy = MoveBy(channel, kind, coords, target)
        words = f"by {_fmt(target)}"
    else:
        points: tuple[tuple[float, ...], ...]
        if kind in (MotionType.ARC, MotionType.CIRCLE):
            if via is None:
                raise UsageError(f"--{motion} needs --via with the via point")
            points = (parse_point(via, "--via"), target)
            words = f"through {_fmt(points[0])} to {_fmt(target)}"
        else:
            if via is not None:
                raise UsageError("--via is for --arc and --circle moves")
            points = (target,)
            words = f"to {_fmt(target)}"
        command = Move(channel, kind, coords, points)
    session.announce(
        f"Channel {channel} will move ({motion}, {coords.name.lower()} coordinates) {words}."
    )
    session.send(command)
    finish_motion(
        session,
        wait,
        wait_timeout,
        {
            "channel": channel,
            "motion": motion,
            "coords": coords.name.lower(),
            "relative": relative,
            "target": list(target),
        },
    )


@click.command("move-point")
@click.argument("file", type=ControllerFile("PNT"))
@click.argument("point", type=click.IntRange(0, 9999))
@click.option(
    "--via",
    "via_point",
    type=click.IntRange(0, 9999),
    default=None,
    help="The via point's number, for --arc and --circle.",
)
@_motion_options
@common_options(channel=True)
@pass_session
def move_point(
    session: ConsoleSession,
    file: str,
    point: int,
    via_point: int | None,
    motion: str,
    wait: bool,
    wait_timeout: float,
) -> None:
    """Move a channel to POINT of the PNT FILE on the controller (BB).

    With --arc the robot moves through point --via to POINT; with --circle it runs a circle
    through point --via and POINT.

    \b
    Example:
      robostar move-point DEMO.PNT 1
      robostar move-point DEMO.PNT 3 --arc --via 2
    """
    kind = _MOTIONS[motion]
    channel = session.channel
    if kind in (MotionType.ARC, MotionType.CIRCLE):
        if via_point is None:
            raise UsageError(f"--{motion} needs --via with the via point's number")
        command = MoveToPoint(channel, file, kind, via_point, point)
        words = f"through point {via_point} to point {point} of {file}"
    else:
        if via_point is not None:
            raise UsageError("--via is for --arc and --circle moves")
        command = MoveToPoint(channel, file, kind, point)
        words = f"to point {point} of {file}"
    session.announce(f"Channel {channel} will move ({motion}) {words}.")
    session.send(command)
    finish_motion(
        session,
        wait,
        wait_timeout,
        {"channel": channel, "motion": motion, "file": file, "point": point, "via": via_point},
    )


def _fmt(values: Sequence[float]) -> str:
    return "(" + ", ".join(f"{v:g}" for v in values) + ")"
