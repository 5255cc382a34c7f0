"""``robostar global``: read and write global integers, floats and points (GR, GW)."""

from __future__ import annotations

import click
from rich.text import Text

from robostar.cli.control import done
from robostar.cli.motion import parse_point
from robostar.cli.options import common_options
from robostar.cli.render import format_number, jsonable
from robostar.cli.session import ConsoleSession, pass_session
from robostar.commands.variables import (
    ReadGlobalFloat,
    ReadGlobalInt,
    ReadGlobalPoint,
    WriteGlobalFloat,
    WriteGlobalInt,
    WriteGlobalPoint,
)
from robostar.errors import UsageError
from robostar.types import ArmForm, CoordSystem, Point

__all__ = ["global_"]

KIND = click.Choice(["int", "float", "point"], case_sensitive=False)
_ARMS = {"left": ArmForm.LEFT, "right": ArmForm.RIGHT, "keep": ArmForm.NONE}


def _index_range(kind: str, index: int) -> None:
    top = 1023 if kind == "point" else 499
    if not 0 <= index <= top:
        raise UsageError(f"a global {kind} index is 0-{top}, not {index}")


@click.group("global")
def global_() -> None:
    """Read and write the controller's global variables: int and float 0-499, point 0-1023.

    \b
    Example:
      robostar global get int 5
      robostar global set point 10 300,200,0,0 --xy --arm left
    """


@global_.command("get")
@click.argument("kind", type=KIND)
@click.argument("index", type=int)
@click.option("--xy", is_flag=True, help="A point in XY rather than joint angles.")
@click.option("--axis", type=click.IntRange(0, 6), default=0, help="One axis of a point (0=all).")
@common_options(channel=True)
@pass_session
def global_get(session: ConsoleSession, kind: str, index: int, xy: bool, axis: int) -> None:
    """Read global KIND (int, float or point) number INDEX.

    \b
    Example:
      robostar global get float 3
      robostar --channel 1 global get point 10 --xy
    """
    kind = kind.lower()
    _index_range(kind, index)
    if kind == "point":
        coords = CoordSystem.XY if xy else CoordSystem.ANGLE
        point = session.send(ReadGlobalPoint(session.channel, index, coords, axis))
        values = "  ".join(format_number(v) for v in point.axes)
        state = "" if point.used else " (unused)"
        session.out.result(
            {
                "kind": kind,
                "index": index,
                "channel": session.channel,
                "coords": coords.name.lower(),
                "axis": axis,
                "point": jsonable(point),
            },
            Text(
                f"Global point {index} (channel {session.channel}): {values}, "
                f"arm {point.arm.name.lower()}{state}"
            ),
        )
        return
    if kind == "int":
        number: float = session.send(ReadGlobalInt(index))
    else:
        number = session.send(ReadGlobalFloat(index))
    session.out.result(
        {"kind": kind, "index": index, "value": number}, Text(f"Global {kind} {index} = {number}")
    )


@global_.command("set", context_settings={"ignore_unknown_options": True})
@click.argument("kind", type=KIND)
@click.argument("index", type=int)
@click.argument("value", nargs=-1, required=True)
@click.option("--xy", is_flag=True, help="A point in XY rather than joint angles.")
@click.option("--axis", type=click.IntRange(0, 6), default=0, help="Write one axis of a point.")
@click.option(
    "--arm",
    type=click.Choice(list(_ARMS)),
    default="keep",
    show_default=True,
    help="A SCARA point's arm form; keep leaves the robot's posture as it is.",
)
@common_options(channel=True)
@pass_session
def global_set(
    session: ConsoleSession,
    kind: str,
    index: int,
    value: tuple[str, ...],
    xy: bool,
    axis: int,
    arm: str,
) -> None:
    """Write global KIND number INDEX: one VALUE, or a point's axis values.

    \b
    Example:
      robostar global set int 5 42
      robostar global set float 3 -1.25
      robostar global set point 10 300 200 0 0 --xy --arm left
      robostar global set point 10 55.5 --axis 3
    """
    kind = kind.lower()
    _index_range(kind, index)
    if kind == "point":
        axes = parse_point(",".join(value), "point")
        if axis and len(axes) != 1:
            raise UsageError(f"--axis {axis} writes one value, not {len(axes)}")
        coords = CoordSystem.XY if xy else CoordSystem.ANGLE
        if arm != "keep" and not xy:
            # In joint angles the arm form follows from the angles themselves (the controller
            # recomputes it), so an --arm here would be silently ignored.
            raise UsageError(
                f"--arm {arm}: with joint angles the arm form follows from the angles; "
                "give the point with --xy to choose the arm form"
            )
        point = Point(axes, _ARMS[arm])
        session.send(WriteGlobalPoint(session.channel, index, point, coords, axis))
        done(
            session,
            f"Global point {index} written.",
            kind=kind,
            index=index,
            channel=session.channel,
            point=jsonable(point),
        )
        return
    if len(value) != 1:
        raise UsageError(f"a global {kind} takes one value, not {len(value)}")
    text = value[0]
    try:
        number: float = int(text) if kind == "int" else float(text)
    except ValueError:
        what = "an integer" if kind == "int" else "a number"
        raise UsageError(f"value {text!r} is not {what}") from None
    if kind == "int":
        session.send(WriteGlobalInt(index, int(number)))
    else:
        session.send(WriteGlobalFloat(index, float(number)))
    done(session, f"Global {kind} {index} = {number}.", kind=kind, index=index, value=number)
