"""``robostar io``: read input and output ports, switch an output, count the I/O boards."""

from __future__ import annotations

import click
from rich.console import Group
from rich.text import Text

from robostar.cli.control import done
from robostar.cli.options import ON_OFF, common_options
from robostar.cli.render import jsonable, lamps_table
from robostar.cli.session import ConsoleSession, pass_session
from robostar.commands.io import ReadInputs, ReadIOBoards, ReadOutputs, SetOutput
from robostar.types import IOState

__all__ = ["io", "port_json"]

PORT = click.IntRange(0, 4)


def port_json(kind: str, state: IOState) -> dict[str, object]:
    return {
        "kind": kind,
        "port": state.port,
        "contacts": jsonable(state.contacts),
        "on": list(state.on),
    }


def _show(session: ConsoleSession, kind: str, state: IOState) -> None:
    on = ", ".join(map(str, state.on)) or "none"
    session.out.result(
        port_json(kind, state),
        lambda: Group(
            lamps_table([(f"{kind} {state.port}", state.contacts)]),
            Text(f"on: {on}", style="dim"),
        ),
    )


@click.group()
def io() -> None:
    """Read and switch the controller's I/O: `io in`, `io out`, `io set`, `io boards`.

    \b
    Example:
      robostar io in 0
      robostar io set 0 3 on
    """


@io.command("in")
@click.argument("port", type=PORT)
@common_options()
@pass_session
def io_in(session: ConsoleSession, port: int) -> None:
    """Show the 16 input contacts of PORT (0-4) as lamps (GA).

    \b
    Example:
      robostar io in 0
    """
    _show(session, "in", session.send(ReadInputs(port)))


@io.command("out")
@click.argument("port", type=PORT)
@common_options()
@pass_session
def io_out(session: ConsoleSession, port: int) -> None:
    """Show the 16 output contacts of PORT (0-4) as lamps (GB).

    \b
    Example:
      robostar io out 0
    """
    _show(session, "out", session.send(ReadOutputs(port)))


@io.command("set")
@click.argument("port", type=PORT)
@click.argument("contact", type=click.IntRange(0, 15))
@click.argument("state", type=ON_OFF)
@common_options()
@pass_session
def io_set(session: ConsoleSession, port: int, contact: int, state: str) -> None:
    """Switch output CONTACT (0-15) of PORT (0-4) on or off (GC).

    \b
    Example:
      robostar io set 0 3 on
    """
    on = state.lower() == "on"
    session.announce(f"Switching output {port}.{contact} {'on' if on else 'off'}.")
    session.send(SetOutput(port, contact, on))
    done(
        session,
        f"Output {port}.{contact} is {'on' if on else 'off'}.",
        port=port,
        contact=contact,
        on=on,
    )


@io.command("boards")
@common_options()
@pass_session
def io_boards(session: ConsoleSession) -> None:
    """Show how many input and output boards the controller has (GD).

    \b
    Example:
      robostar io boards
    """
    inputs, outputs = session.send(ReadIOBoards())
    session.out.result(
        {"input_boards": inputs, "output_boards": outputs},
        Text(f"I/O boards: {inputs} input, {outputs} output"),
    )
