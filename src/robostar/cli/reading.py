"""Reading commands: status, info, alarms, position, params, last-error."""

from __future__ import annotations

from collections.abc import Sequence

import click
from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from robostar.cli.options import common_options
from robostar.cli.render import STATUS_BITS, format_number, jsonable, lamp
from robostar.cli.session import ConsoleSession, pass_session
from robostar.commands.files import ReadAlarmHistory
from robostar.commands.status import ReadAlarms, ReadInfo, ReadPosition, ReadStatus
from robostar.commands.system import ReadLastError, ReadParameters
from robostar.types import Alarm, AlarmRecord, ChannelStatus, ControllerInfo, Position, PositionKind

__all__ = [
    "alarm_table",
    "alarms",
    "info",
    "info_view",
    "last_error",
    "params",
    "position",
    "position_view",
    "status",
    "status_json",
    "status_table",
]

KINDS = {"pulse": PositionKind.PULSE, "angle": PositionKind.ANGLE, "xy": PositionKind.XY}
_UNITS = {PositionKind.PULSE: "pulses", PositionKind.ANGLE: "deg/mm", PositionKind.XY: "mm/deg"}


def status_json(statuses: Sequence[ChannelStatus]) -> dict[str, object]:
    return {"channels": [{"channel": i, **jsonable(s)} for i, s in enumerate(statuses, 1)]}


def status_table(statuses: Sequence[ChannelStatus]) -> Table:
    table = Table(title="Status", title_justify="left")
    table.add_column("channel", justify="right")
    for name in STATUS_BITS:
        table.add_column(name.replace("_", " "), justify="center")
    for i, s in enumerate(statuses, 1):
        cells = [
            lamp(getattr(s, name), "on" if getattr(s, name) else "off", alarm=name == "alarm")
            for name in STATUS_BITS
        ]
        table.add_row(str(i), *cells)
    return table


def info_view(info: ControllerInfo) -> RenderableType:
    head = Text(f"{info.name}  version {info.version}  ({info.max_channels} channel(s))", "bold")
    table = Table(box=None, pad_edge=False)
    for column in ("channel", "model", "type", "max axes", "axes in use"):
        table.add_column(column)
    for ch in info.channels:
        table.add_row(
            str(ch.channel),
            ch.model or "-",
            ch.robot_type.name.lower().replace("_", " "),
            str(ch.max_axes),
            ",".join(map(str, ch.axes_in_use)) or "-",
        )
    return Group(head, table)


def alarm_table(current: Sequence[Alarm]) -> RenderableType:
    if not current:
        return Text("No alarms.", style="green")
    table = Table(title="Current alarms", title_justify="left")
    table.add_column("code", justify="right")
    table.add_column("alarm")
    for alarm in current:
        table.add_row(Text(f"{alarm.code:04d}", "bold red"), Text(alarm.text))
    return table


def history_table(records: Sequence[AlarmRecord]) -> RenderableType:
    if not records:
        return Text("The alarm history is empty.")
    table = Table(title="Alarm history", title_justify="left")
    for column in ("page", "no.", "work time", "channel", "alarm", "detail", "code"):
        table.add_column(column)
    for r in records:
        table.add_row(
            str(r.page),
            str(r.index),
            f"{r.day}D {r.hours:02d}:{r.minutes:02d}:{r.seconds:02d}",
            "all" if r.channel == 9 else str(r.channel),
            Text(r.text),
            Text(r.detail),
            str(r.code),
        )
    return table


def position_view(channel: int, pos: Position) -> RenderableType:
    table = Table(
        title=f"Channel {channel} position ({pos.kind.name.lower()})", title_justify="left"
    )
    for axis in range(1, len(pos.axes) + 1):
        table.add_column(f"axis {axis}", justify="right")
    cells = [
        str(round(v)) if pos.kind is PositionKind.PULSE else format_number(v) for v in pos.axes
    ]
    table.add_row(*cells)
    parts: list[RenderableType] = [table]
    note = f"units: {_UNITS[pos.kind]}"
    if pos.arm.name != "NONE":
        note += f"; arm {pos.arm.name.lower()}"
    parts.append(Text(note, style="dim"))
    return Group(*parts)


def position_json(channel: int, pos: Position) -> dict[str, object]:
    return {"channel": channel, **jsonable(pos)}


@click.command()
@common_options()
@pass_session
def status(session: ConsoleSession) -> None:
    """Show the status lamps of every channel: servo, origin, alarm, ready, in position, running.

    \b
    Example:
      robostar status
      robostar --json status
    """
    statuses = session.send(ReadStatus())
    session.out.result(status_json(statuses), lambda: status_table(statuses))


@click.command()
@common_options()
@pass_session
def info(session: ConsoleSession) -> None:
    """Show the controller's name and version, and each channel's model, type and axes.

    \b
    Example:
      robostar info
    """
    data = session.send(ReadInfo())
    session.out.result(jsonable(data), lambda: info_view(data))


@click.command()
@click.option("--history", is_flag=True, help="Show the stored alarm history (FH) instead.")
@common_options()
@pass_session
def alarms(session: ConsoleSession, history: bool) -> None:
    """Show the current alarms (up to 10), or with --history the stored alarm history.

    Clear current alarms with `robostar reset`.

    \b
    Example:
      robostar alarms
      robostar alarms --history
    """
    if history:
        records = session.send(ReadAlarmHistory())
        session.out.result({"history": jsonable(records)}, lambda: history_table(records))
        return
    current = session.send(ReadAlarms())
    session.out.result({"alarms": jsonable(current)}, lambda: alarm_table(current))


@click.command()
@click.option(
    "--kind",
    type=click.Choice(list(KINDS)),
    default="xy",
    show_default=True,
    help="pulse (encoder pulses), angle (joint degrees, mm on a linear axis) or xy.",
)
@common_options(channel=True)
@pass_session
def position(session: ConsoleSession, kind: str) -> None:
    """Show a channel's position in pulses, joint angles or XY, with the arm form.

    \b
    Example:
      robostar position --kind angle
      robostar --channel 2 --json position
    """
    pos = session.send(ReadPosition(session.channel, KINDS[kind]))
    session.out.result(
        position_json(session.channel, pos), lambda: position_view(session.channel, pos)
    )


@click.command()
@click.option(
    "--index",
    type=click.IntRange(-1, 99),
    default=-1,
    show_default=True,
    help="The parameter group (1-99, the manual's table), or -1 for all.",
)
@click.option("--public", is_flag=True, help="The public parameters instead of a channel's.")
@common_options(channel=True)
@pass_session
def params(session: ConsoleSession, index: int, public: bool) -> None:
    """Show a channel's parameter data (KE), or the public parameters with --public.

    \b
    Example:
      robostar params
      robostar params --public --index 1
    """
    channel = None if public else session.channel
    lines = session.send(ReadParameters(channel, index))

    def view() -> RenderableType:
        title = "Public parameters" if channel is None else f"Channel {channel} parameters"
        table = Table(title=title, title_justify="left", box=None)
        table.add_column("#", justify="right")
        table.add_column("data")
        for i, line in enumerate(lines, 1):
            table.add_row(str(i), Text(line))
        return table

    session.out.result({"channel": channel, "index": index, "parameters": list(lines)}, view)


@click.command("last-error")
@common_options()
@pass_session
def last_error(session: ConsoleSession) -> None:
    """Show the controller's reason for the last refused command (KD).

    \b
    Example:
      robostar last-error
    """
    text = session.send(ReadLastError())
    session.out.result({"last_error": text}, lambda: Text(text or "(no error recorded)"))
