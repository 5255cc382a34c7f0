"""``robostar sim``: serve the virtual N1 on TCP and/or a pseudo-terminal until Ctrl-C."""

from __future__ import annotations

import dataclasses
import json
import sys
from collections.abc import Callable
from urllib.parse import parse_qsl

import click
from rich.text import Text

from robostar.cli.options import Finite, common_options
from robostar.cli.session import ConsoleSession, pass_session
from robostar.errors import UsageError

__all__ = ["sim", "sim_input"]


@click.group(invoke_without_command=True)
@click.option(
    "--listen",
    default="127.0.0.1:9100",
    show_default=True,
    metavar="HOST:PORT",
    help="TCP address to serve on (port 0 picks a free one; 'none' for no TCP).",
)
@click.option("--pty", is_flag=True, help="Also serve on a pseudo-terminal (a serial device).")
@click.option(
    "--count",
    type=click.IntRange(1, 32),
    default=1,
    show_default=True,
    help="Controllers to serve, on consecutive ports.",
)
@click.option(
    "--state",
    "state_dir",
    type=click.Path(file_okay=False),
    default=None,
    metavar="DIR",
    help="Keep the controllers' files and variables in DIR across runs.",
)
@click.option(
    "--fault",
    "faults",
    multiple=True,
    metavar="SPEC",
    help="Inject line faults, e.g. corrupt:0.01, drop:to_host:0.005, delay:0.5@3.",
)
@click.option(
    "--baud",
    type=click.IntRange(300, 4_000_000),
    default=None,
    help="Pace the bytes as a serial line at this baud rate.",
)
@click.option(
    "--turnaround",
    type=Finite(0.0, 5.0),
    default=0.0,
    metavar="SECONDS",
    help="Delay before each answer leaves, like a real controller's.",
)
@click.option(
    "--config",
    "config_file",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="The controller's configuration (TOML, see docs/simulator.md).",
)
@click.option(
    "--options",
    "query",
    default=None,
    metavar="QUERY",
    help="Configuration as a sim:// query instead, e.g. channels=1&robot=xy&speedup=5.",
)
@click.option(
    "--control",
    default=None,
    metavar="HOST:PORT",
    help="Open a loopback control socket for `robostar sim-input` (set inputs, raise alarms).",
)
@click.option(
    "--allow-remote",
    is_flag=True,
    help="Allow a non-loopback --listen address (the simulator has no security).",
)
@click.option(
    "--dialect",
    default=None,
    metavar="NAME",
    help="Write answers as another controller may: manual (default), capacity, left-aligned, "
    "padded (docs/simulator.md, Dialects).",
)
@click.option(
    "--replay",
    "replay_file",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    metavar="TRACE",
    help="Answer from a recorded --trace instead of the model (reports where the host differs).",
)
@click.option(
    "--journal",
    "journal_file",
    type=click.Path(dir_okay=False),
    default=None,
    metavar="FILE",
    help="Append every state change the simulator carries out to FILE (JSONL, see "
    "docs/simulator.md, Journal).",
)
@common_options()
@pass_session
def sim(
    session: ConsoleSession,
    listen: str,
    pty: bool,
    count: int,
    state_dir: str | None,
    faults: tuple[str, ...],
    baud: int | None,
    turnaround: float,
    config_file: str | None,
    query: str | None,
    control: str | None,
    allow_remote: bool,
    dialect: str | None,
    replay_file: str | None,
    journal_file: str | None,
) -> None:
    """Run the simulator: a virtual N1 for other programs (or another robostar) to talk to.

    `robostar sim alarm raise CODE` / `clear` act on a running one (see `sim alarm --help`).

    Each endpoint is printed when it is ready (with --json, one JSON line listing them); point
    --port at it. Ctrl-C or SIGTERM stops it.

    \b
    Example:
      robostar sim --listen 127.0.0.1:9100
      robostar --port tcp://127.0.0.1:9100 status     # in another terminal
      robostar sim --pty --listen none --fault corrupt:0.01
      robostar sim --control 127.0.0.1:9199     # then: robostar sim-input 0 3 on
      robostar sim --dialect capacity            # FA announces 2000, as some N1s do
      robostar sim --replay field.trace          # answer as a recorded controller did
      robostar sim --journal run.jsonl           # what it carried out, when: test evidence
    """
    if click.get_current_context().invoked_subcommand is not None:
        return
    from robostar.sim import SimConfig
    from robostar.sim.listeners import serve

    if config_file and query:
        raise UsageError("give --config or --options, not both")
    if config_file:
        config = SimConfig.from_file(config_file)
    elif query:
        config = SimConfig.from_query(dict(parse_qsl(query, keep_blank_values=True)))
    else:
        config = SimConfig()
    if dialect is not None:
        try:
            config = dataclasses.replace(config, dialect=dialect)
        except UsageError as exc:  # an unknown name: the names, and how to pick one
            from robostar.sim.dialects import DIALECTS

            exc.hint = (  # type: ignore[attr-defined]
                f"Give one of the names above, e.g. `robostar sim --dialect "
                f"{next(iter(DIALECTS))}` (`robostar sim --help` says what each one changes)."
            )
            raise
    if journal_file is not None:
        config = dataclasses.replace(config, journal=journal_file)
    address = None if listen.strip().lower() in ("", "none") else listen
    if replay_file is not None:
        from robostar.sim.replay import serve_replay

        serve_replay(
            replay_file, listen=address, allow_remote=allow_remote, on_ready=ready_printer(session)
        )
        return

    serve(
        config,
        listen=address,
        pty=pty,
        count=count,
        state_dir=state_dir,
        faults=list(faults),
        baud=baud,
        turnaround=turnaround,
        allow_remote=allow_remote,
        on_ready=ready_printer(session),
        control=control,
    )


def ready_printer(session: ConsoleSession) -> Callable[[list[str]], None]:
    """Prints the endpoints once they serve (one JSON line with --json)."""

    def ready(endpoints: list[str]) -> None:
        if session.out.json:
            click.echo(json.dumps({"ready": True, "endpoints": endpoints}))
        else:
            for endpoint in endpoints:
                click.echo(endpoint)
            session.out.note("Simulator running; Ctrl-C stops it.")
        sys.stdout.flush()

    return ready


@click.command("sim-input")
@click.argument("port", type=click.IntRange(0, 4))
@click.argument("contact", type=click.IntRange(0, 15))
@click.argument("state", type=click.Choice(["on", "off"], case_sensitive=False))
@click.option(
    "--control",
    default="127.0.0.1:9199",
    show_default=True,
    metavar="HOST:PORT",
    help="The control socket a `robostar sim --control` opened.",
)
@click.option(
    "--controller",
    type=click.IntRange(1, 32),
    default=1,
    show_default=True,
    help="Which controller, when the simulator serves several (--count).",
)
@common_options()
@pass_session
def sim_input(
    session: ConsoleSession, port: int, contact: int, state: str, control: str, controller: int
) -> None:
    """Set an input contact of a running simulator (a sensor, a push button).

    \b
    Example:
      robostar sim --control 127.0.0.1:9199 &
      robostar sim-input 0 3 on                  # port 0, contact 3 on
      robostar --port tcp://127.0.0.1:9100 io in 0
    """
    _control(control, f"input {port} {contact} {state.lower()} {controller}")
    if session.out.json:
        click.echo(json.dumps({"port": port, "contact": contact, "on": state.lower() == "on"}))
    else:
        click.echo(f"input {port}.{contact} {state.lower()}")


@sim.group("alarm")
def sim_alarm() -> None:
    """Raise an alarm in a running simulator (its control socket), or clear its alarms.

    \b
    Example:
      robostar sim --control 127.0.0.1:9199 &
      robostar sim alarm raise 1153 --channel 1
      robostar --port tcp://127.0.0.1:9100 sim alarm clear
    """


@sim_alarm.command("raise")
@click.argument("code", type=click.IntRange(0, 9999))
@click.option(
    "--channel",
    "alarm_channel",
    type=click.Choice(["1", "2", "3", "9"]),
    default="9",
    show_default=True,
    help="The channel it belongs to (9: all).",
)
@click.option(
    "--control",
    default="127.0.0.1:9199",
    show_default=True,
    metavar="HOST:PORT",
    help="The control socket a `robostar sim --control` opened.",
)
@click.option("--controller", type=click.IntRange(1, 32), default=1, show_default=True)
@common_options()
@pass_session
def sim_alarm_raise(
    session: ConsoleSession, code: int, alarm_channel: str, control: str, controller: int
) -> None:
    """Raise alarm CODE in a running simulator, as a fault on the robot would.

    \b
    Example:
      robostar sim alarm raise 1153 --channel 1
    """
    _control(control, f"alarm {code} {alarm_channel} {controller}")
    session.out.result(
        {"ok": True, "code": code, "channel": int(alarm_channel), "simulator": True},
        Text(f"SIMULATOR: alarm {code} raised on channel {alarm_channel}."),
    )


@sim_alarm.command("clear")
@common_options()
@pass_session
def sim_alarm_clear(session: ConsoleSession) -> None:
    """Clear a simulator's alarms (CG over --port, which must be a simulator).

    \b
    Example:
      robostar --port tcp://127.0.0.1:9100 sim alarm clear
    """
    from robostar.commands.control import ResetAlarms
    from robostar.commands.identity import is_simulator_identity

    client = session.client
    info = client.info()
    if not (session.simulator or is_simulator_identity(info)):
        raise UsageError(
            f"--port: {session.port} is a real controller ({info.name}); clear its alarms with "
            "`robostar reset` once the cause is fixed"
        )
    client.execute(ResetAlarms())
    session.out.result(
        {"ok": True, "cleared": True}, Text("SIMULATOR: alarms cleared.", style="green")
    )


def _control(control: str, line: str) -> None:
    """Send ``line`` to the control socket of a running simulator at ``control``; a clear
    error when there is none, or when it refuses the line."""
    from robostar.sim.control import send_control
    from robostar.sim.listeners import parse_listen

    try:
        answer = send_control(parse_listen(control), line)
    except OSError as error:
        raise UsageError(
            f"no simulator control socket at {control} ({error}); start one with "
            f"`robostar sim --control {control}`"
        ) from None
    if answer != "ok":
        raise UsageError(f"the simulator refused: {answer.removeprefix('error: ')}")
