"""``robostar teach``: store the current position into a point, and go to a stored point slowly.

A point of a PNT file is taught by reading the file (FA, joint angles), replacing the one point
and writing the file back (FB, verified by the client); a global point is written with GW.
Both show the old and the new value and ask first. ``goto`` moves to a stored point at a low
speed after a confirmation, and puts the channel's speed back afterwards.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import click
from rich.table import Table
from rich.text import Text

from robostar.cli.options import ControllerFile, common_options
from robostar.cli.render import format_number, jsonable
from robostar.cli.session import ConsoleSession, pass_session
from robostar.errors import UsageError
from robostar.types import ArmForm, Point, PositionKind, RobotType

if TYPE_CHECKING:
    from robostar.client import Client

__all__ = [
    "GOTO_SPEED",
    "Target",
    "current_point",
    "goto",
    "point_text",
    "read_point",
    "teach",
    "teach_point",
    "write_point",
]

GOTO_SPEED = 100
"""Speed (0-1000, so 10 %) of a move to a taught point: slow enough to stop by hand."""


@dataclass(frozen=True, slots=True)
class Target:
    """A point to teach: ``number`` of the PNT ``file``, or global point ``number``."""

    number: int
    file: str | None = None

    def __str__(self) -> str:
        return f"point {self.number} of {self.file}" if self.file else f"global point {self.number}"


def _check(target: Target) -> None:
    top = 1023 if target.file is None else 999
    if not 0 <= target.number <= top:
        raise UsageError(f"number: {target.number} is out of range 0-{top}")


def read_point(client: Client, channel: int, target: Target) -> Point | None:
    """The stored point (None when the file has no such point), in joint angles."""
    _check(target)
    if target.file is None:
        point = client.read_global_point(channel, target.number)
        return point if point.used else None
    return client.download_points(channel, target.file).points.get(target.number)


def current_point(client: Client, channel: int) -> Point:
    angles = client.position(channel, PositionKind.ANGLE)
    arm = ArmForm.NONE
    info = client.info().channel(channel)
    if info.robot_type is RobotType.SCARA:
        arm = client.position(channel, PositionKind.XY).arm
    return Point(tuple(angles.axes), arm, True)


def write_point(client: Client, channel: int, target: Target, point: Point) -> None:
    _check(target)
    if target.file is None:
        client.write_global_point(channel, target.number, point)
        return
    points = dict(client.download_points(channel, target.file).points)
    points[target.number] = point
    client.upload_points(channel, target.file, points)


def teach_point(
    client: Client,
    channel: int,
    target: Target,
    confirm: Callable[[Point | None, Point], bool],
) -> tuple[Point | None, Point, bool]:
    """Show old and new to ``confirm``; write only when it agrees. (old, new, written)."""
    old = read_point(client, channel, target)
    new = current_point(client, channel)
    if not confirm(old, new):
        return old, new, False
    write_point(client, channel, target, new)
    return old, new, True


def point_text(point: Point | None) -> str:
    if point is None:
        return "(empty)"
    arm = f" arm {point.arm.name.lower()}" if point.arm is not ArmForm.NONE else ""
    return "(" + ", ".join(format_number(v) for v in point.axes) + ")" + arm


@click.group()
def teach() -> None:
    """Teach points: store the current position, or go to a stored point slowly.

    \b
    Example:
      robostar --port sim:// teach store DEMO.PNT 5
      robostar --port sim:// teach store --global 100 --yes
      robostar --port sim:// teach goto DEMO.PNT 5
    """


@teach.command("store")
@click.argument("where", nargs=-1, required=True, metavar="[FILE.PNT] NUMBER")
@click.option("--global", "global_", is_flag=True, help="A global point (GW) instead of a file.")
@click.option("--yes", "-y", is_flag=True, help="Do not ask for confirmation.")
@common_options(channel=True)
@pass_session
def store(session: ConsoleSession, where: tuple[str, ...], global_: bool, yes: bool) -> None:
    """Store the current position into point NUMBER of FILE.PNT (or global point NUMBER).

    Shows the old and the new value and asks first (--yes skips the question).

    \b
    Example:
      robostar --port sim:// teach store DEMO.PNT 5
      robostar --port sim:// teach store --global 100 --yes
    """
    target = _parse_where(where, global_)
    channel = session.channel
    if session.dry_run:
        raise UsageError("--dry-run: teach reads the position first; run it without --dry-run")

    def confirm(old: Point | None, new: Point) -> bool:
        if not session.out.json:
            session.out.console.print(_compare(target, old, new))
        if yes:
            return True
        if session.out.json:
            raise UsageError("--yes: a --json teach cannot ask; give --yes")
        return click.confirm(f"Store the current position into {target}?")

    old, new, written = teach_point(session.client, channel, target, confirm)
    data = {
        "ok": written,
        "channel": channel,
        "target": {"file": target.file, "number": target.number},
        "old": jsonable(old),
        "new": jsonable(new),
        "written": written,
    }
    text = f"Stored in {target}." if written else "Nothing was written."
    session.out.result(data, Text(text, style="green" if written else "yellow"))
    if not written:
        raise click.exceptions.Exit(1)


@teach.command("goto")
@click.argument("where", nargs=-1, required=True, metavar="[FILE.PNT] NUMBER")
@click.option("--global", "global_", is_flag=True, help="A global point instead of a file.")
@click.option(
    "--speed",
    type=click.IntRange(1, 1000),
    default=GOTO_SPEED,
    show_default=True,
    help="Speed for the move (0-1000); the channel's speed is put back afterwards.",
)
@click.option("--yes", "-y", is_flag=True, help="Do not ask for confirmation.")
@common_options(channel=True)
@pass_session
def goto_command(
    session: ConsoleSession, where: tuple[str, ...], global_: bool, speed: int, yes: bool
) -> None:
    """Move slowly (joint motion) to point NUMBER of FILE.PNT, or to global point NUMBER.

    \b
    Example:
      robostar --port sim:// teach goto DEMO.PNT 5
    """
    target = _parse_where(where, global_)
    channel = session.channel
    if session.dry_run:
        raise UsageError("--dry-run: goto reads the point first; run it without --dry-run")
    point = read_point(session.client, channel, target)
    if point is None:
        raise UsageError(f"{target} is empty: teach it first with `robostar teach store`")
    if not session.out.json:
        session.out.console.print(Text(f"{target}: {point_text(point)}"))
    if not yes:
        if session.out.json:
            raise UsageError("--yes: a --json goto cannot ask; give --yes")
        if not click.confirm(f"Move channel {channel} to {target} at speed {speed}?"):
            session.out.result({"ok": False, "moved": False}, Text("Not moved.", style="yellow"))
            raise click.exceptions.Exit(1)
    session.announce(f"Channel {channel} will move to {target} at speed {speed}.")
    goto(session.client, channel, target, point, speed)
    session.out.result(
        {"ok": True, "moved": True, "channel": channel, "point": jsonable(point)},
        Text(f"Channel {channel} is at {target}.", style="green"),
    )


def goto(client: Client, channel: int, target: Target, point: Point, speed: int) -> None:
    """Move to ``target`` at ``speed``, waiting until it stops; the old speed is put back."""
    before = client.speed(channel)
    client.set_speed(channel, speed)
    try:
        if target.file is not None:
            client.move_to_point(channel, target.file, target.number, motion="joint", wait=True)
        else:
            axes = len(client.info().channel(channel).axes_in_use) or len(point.axes)
            client.move(channel, point.axes[:axes], motion="joint", coords="angle", wait=True)
    finally:
        client.set_speed(channel, before)


def _parse_where(where: tuple[str, ...], global_: bool) -> Target:
    if global_:
        if len(where) != 1:
            raise UsageError("--global takes one NUMBER, no file")
        file, number = None, where[0]
    else:
        if len(where) != 2:
            raise UsageError("give FILE.PNT NUMBER (or --global NUMBER)")
        file = ControllerFile("PNT").convert(where[0], None, None)
        number = where[1]
    try:
        value = int(number)
    except ValueError:
        raise UsageError(f"number: {number!r} is not a whole number") from None
    target = Target(value, file)
    _check(target)
    return target


def _compare(target: Target, old: Point | None, new: Point) -> Table:
    table = Table(title=f"Teach {target}", title_justify="left")
    table.add_column("")
    table.add_column("value")
    table.add_row("old", point_text(old))
    table.add_row("new (here)", Text(point_text(new), style="bold"))
    return table
