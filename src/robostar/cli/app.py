"""The root ``robostar`` group: global options, lazy subcommands, and errors turned into exit codes.

Subcommands live in their own modules and are imported only when used (click's lazy-group
pattern), so ``robostar decode`` starts without loading the client or the simulator.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from typing import Any

import click

from robostar import __version__
from robostar.cli.failures import EXIT_INTERRUPTED, EXIT_LINE, Failure, explain
from robostar.cli.render import Output
from robostar.cli.session import DryRunDone, Session, Settings
from robostar.errors import RobostarError

__all__ = ["SUBCOMMANDS", "RobostarGroup", "cli", "main"]

SUBCOMMANDS: dict[str, str] = {
    # reading
    "status": "robostar.cli.reading:status",
    "info": "robostar.cli.reading:info",
    "alarms": "robostar.cli.reading:alarms",
    "position": "robostar.cli.reading:position",
    "params": "robostar.cli.reading:params",
    "last-error": "robostar.cli.reading:last_error",
    # acting
    "servo": "robostar.cli.control:servo",
    "home": "robostar.cli.motion:home",
    "move": "robostar.cli.motion:move",
    "move-point": "robostar.cli.motion:move_point",
    "speed": "robostar.cli.control:speed",
    "job": "robostar.cli.jobs:job",
    "io": "robostar.cli.inout:io",
    "global": "robostar.cli.variables:global_",
    "estop": "robostar.cli.control:estop",
    "reset": "robostar.cli.control:reset",
    "restart": "robostar.cli.control:restart",
    "ref-axis": "robostar.cli.control:ref_axis",
    # files
    "files": "robostar.cli.files:files",
    "backup": "robostar.cli.files:backup",
    "restore": "robostar.cli.files:restore",
    # live
    "jog": "robostar.cli.jogpad:jog",
    "monitor": "robostar.cli.monitor:monitor",
    # engineering
    "raw": "robostar.cli.raw:raw",
    "decode": "robostar.cli.decode:decode",
    "doctor": "robostar.cli.doctor:doctor",
    "sim": "robostar.cli.simcmd:sim",
    "sim-input": "robostar.cli.simcmd:sim_input",
    "demo": "robostar.cli.demo:demo",
    "serve": "robostar.cli.serve:serve",
}


class RobostarGroup(click.Group):
    """The root group: loads subcommands on demand and reports errors as sentences."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return [*SUBCOMMANDS, *super().list_commands(ctx)]

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        target = SUBCOMMANDS.get(cmd_name)
        if target is None:
            return super().get_command(ctx, cmd_name)
        module_name, attr = target.split(":")
        command = getattr(importlib.import_module(module_name), attr)
        if not isinstance(command, click.Command):
            raise TypeError(f"{target} is not a click command")
        return command

    def invoke(self, ctx: click.Context) -> Any:
        try:
            try:
                return super().invoke(ctx)
            finally:
                session = ctx.find_object(Session)
                if session is not None:
                    session.close()
        except DryRunDone:
            ctx.exit(0)
        except RobostarError as error:
            session = ctx.find_object(Session)
            port = session.settings.port if session else "?"
            out = session.out if session else Output(False)
            failure = explain(error, port)
            out.failure(failure)
            ctx.exit(failure.exit_code)
        except KeyboardInterrupt:
            session = ctx.find_object(Session)
            out = session.out if session else Output(False)
            out.failure(Failure(EXIT_INTERRUPTED, "Interrupted.", "", "KeyboardInterrupt"))
            ctx.exit(EXIT_INTERRUPTED)
        except OSError as error:
            # A port that fails mid-run without the client wrapping it: still a line failure.
            session = ctx.find_object(Session)
            out = session.out if session else Output(False)
            text = f"The port failed: {error}."
            hint = "Check the cable and --port; `robostar doctor` checks the line."
            out.failure(Failure(EXIT_LINE, text, hint, type(error).__name__))
            ctx.exit(EXIT_LINE)


@click.group(cls=RobostarGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.option(
    "--port",
    "-p",
    envvar="ROBOSTAR_PORT",
    default="sim://",
    show_default=True,
    metavar="URL",
    help="The controller: /dev/ttyUSB0, serial://PATH?baudrate=N, tcp://HOST:PORT, or sim:// "
    "(the built-in simulator). Also from ROBOSTAR_PORT.",
)
@click.option(
    "--timeout",
    type=click.FloatRange(min=0.01),
    default=None,
    metavar="SECONDS",
    help="Reply timeout (default 2 s, as the manual says).",
)
@click.option("--json", "json_mode", is_flag=True, help="Machine-readable output (JSON).")
@click.option(
    "--trace",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    metavar="FILE",
    help="Write every frame sent and received to FILE as JSON lines (read it with `decode`).",
)
@click.option(
    "--channel",
    "-c",
    type=click.IntRange(1, 3),
    default=1,
    show_default=True,
    help="Channel 1-3, for the commands that need one.",
)
@click.option(
    "--dry-run",
    is_flag=True,
    help="Print the frames a command would send, and send nothing.",
)
@click.version_option(__version__, prog_name="robostar")
@click.pass_context
def cli(
    ctx: click.Context,
    port: str,
    timeout: float | None,
    json_mode: bool,
    trace: str | None,
    channel: int,
    dry_run: bool,
) -> None:
    """robostar: the technician's console for a Robostar N1 controller.

    Every command talks to the controller at --port; with no port it starts the built-in
    simulator, so you can try everything safely. Exit codes: 0 done, 2 bad argument,
    3 refused by the controller (with its reason), 4 the line failed.

    \b
    Examples:
      robostar demo                               # a guided tour on the simulator
      robostar --port /dev/ttyUSB0 status
      robostar --port tcp://127.0.0.1:9100 --json position --kind xy
      robostar --dry-run move 100 200 0 0          # show the frames, send nothing
    """
    ctx.obj = Session(Settings(port, timeout, json_mode, trace, channel, dry_run))


def main(argv: Sequence[str] | None = None) -> None:
    """The console entry point."""
    cli.main(args=list(argv) if argv is not None else None, prog_name="robostar")
