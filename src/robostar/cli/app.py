"""The root ``robostar`` group: global options, lazy subcommands, and errors turned into exit codes.

Subcommands live in their own modules and are imported only when used (click's lazy-group
pattern), so ``robostar decode`` starts without loading the client or the simulator.
"""

from __future__ import annotations

import errno
import importlib
import json
import sys
from collections.abc import Sequence
from typing import Any

import click

from robostar import __version__
from robostar.cli.failures import (
    EXIT_BAD_ARGUMENT,
    EXIT_INTERRUPTED,
    EXIT_LINE,
    Failure,
    explain,
    with_alarms_left,
)
from robostar.cli.options import Finite
from robostar.cli.render import Output
from robostar.cli.session import ConsoleSession, DryRunDone, Settings
from robostar.errors import ControllerError, RobostarError, UsageError

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
    "trace": "robostar.cli.trace:trace",
    "doctor": "robostar.cli.doctor:doctor",
    "sim": "robostar.cli.simcmd:sim",
    "sim-input": "robostar.cli.simcmd:sim_input",
    "demo": "robostar.cli.demo:demo",
    "profiles": "robostar.cli.profilecmd:profiles",
    "teach": "robostar.cli.teach:teach",
    "shell": "robostar.cli.shell:shell",
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

    def make_context(
        self,
        info_name: str | None,
        args: list[str],
        parent: click.Context | None = None,
        **extra: Any,
    ) -> click.Context:
        json_mode = "--json" in args  # before parsing, which consumes ``args``
        try:
            return super().make_context(info_name, args, parent, **extra)
        except click.UsageError as error:
            # The root's own options failed to parse: no session yet, so look for --json here.
            if json_mode:
                _json_usage_error(error)
                raise click.exceptions.Exit(EXIT_BAD_ARGUMENT) from error
            raise

    def invoke(self, ctx: click.Context) -> Any:
        try:
            try:
                return super().invoke(ctx)
            except RobostarError as error:
                if _refused(error):
                    # Read before the connection closes: did the refusal leave an alarm?
                    session = ctx.find_object(ConsoleSession)
                    if session is not None:
                        session.read_alarms_left()
                raise
            except KeyboardInterrupt:
                session = ctx.find_object(ConsoleSession)
                if session is not None:
                    session.interrupt_note = session.interrupt_note or session.interrupted_during()
                    session.stop_started_motion()
                raise
            finally:
                session = ctx.find_object(ConsoleSession)
                if session is not None:
                    session.close()
        except DryRunDone:
            ctx.exit(0)
        except click.UsageError as error:
            session = ctx.find_object(ConsoleSession)
            if session is None or not session.out.json:
                raise
            _json_usage_error(error, session.frames_sent, session.changes_sent, session.out.extra)
            ctx.exit(EXIT_BAD_ARGUMENT)
        except RobostarError as error:
            session = ctx.find_object(ConsoleSession)
            port = session.port_label if session else "?"
            out = session.out if session else Output(False)
            sent = (session.frames_sent, session.changes_sent) if session else (0, 0)
            failure = explain(error, port, *sent)
            if _refused(error) and session is not None:
                failure = with_alarms_left(failure, session.alarms_left)
            out.failure(failure)
            ctx.exit(failure.exit_code)
        except KeyboardInterrupt as interrupt:
            session = ctx.find_object(ConsoleSession)
            out = session.out if session else Output(False)
            out.failure(_interrupted(interrupt, session))
            ctx.exit(EXIT_INTERRUPTED)
        except OSError as error:
            session = ctx.find_object(ConsoleSession)
            out = session.out if session else Output(False)
            if _is_local(error):
                # A file on this computer (disk full, no permission): not the line's fault.
                where = f" {error.filename}" if error.filename else ""
                text = f"Cannot use the local file{where}: {error.strerror or error}."
                hint = "Free space on that disk or check its permissions; the line is not at fault."
                out.failure(Failure(EXIT_BAD_ARGUMENT, text, hint, type(error).__name__))
                ctx.exit(EXIT_BAD_ARGUMENT)
            # A port that fails mid-run without the client wrapping it: still a line failure.
            text = f"The port failed: {error}."
            hint = "Check the cable and --port; `robostar doctor` checks the line."
            out.failure(Failure(EXIT_LINE, text, hint, type(error).__name__))
            ctx.exit(EXIT_LINE)


def _refused(error: RobostarError) -> bool:
    """Did the controller refuse a command, itself or as what stopped a restore part-way (a
    refusal may leave an alarm that the message should name)?"""
    if isinstance(error, ControllerError):
        return True
    backup = sys.modules.get("robostar.backup.errors")  # loaded if a restore was running
    return (
        backup is not None
        and isinstance(error, backup.RestoreIncompleteError)
        and isinstance(error.__cause__, ControllerError)
    )


_LOCAL_ERRNOS = frozenset(
    getattr(errno, name)
    for name in ("ENOSPC", "EDQUOT", "EFBIG", "EROFS", "EACCES", "EPERM", "EISDIR", "ENOTDIR")
    if hasattr(errno, name)
)


def _is_local(error: OSError) -> bool:
    """An error of a file on this computer rather than of the port."""
    return error.filename is not None or error.errno in _LOCAL_ERRNOS


def _interrupted(interrupt: KeyboardInterrupt, session: ConsoleSession | None) -> Failure:
    """Ctrl-C as the console says it: what was on the line, what was stopped; for a restore,
    which files are written, in doubt and not touched."""
    backup = sys.modules.get("robostar.backup.errors")  # loaded if a restore was running
    stopped = session.stopped_on_interrupt if session else ""
    if backup is not None and isinstance(interrupt, backup.RestoreInterrupted):
        state = interrupt.state
        text = f"Interrupted: {state.describe()}."
        return Failure(
            EXIT_INTERRUPTED, text, state.hint, "KeyboardInterrupt", restore=state.as_json()
        )
    during = session.interrupt_note if session else ""
    if during and stopped:
        text = f"Interrupted: {during}; {stopped}."
    elif during:
        text = f"Interrupted: {during}."
    elif stopped:
        text = f"Interrupted; {stopped}."
    else:
        text = "Interrupted."
    return Failure(EXIT_INTERRUPTED, text, "", "KeyboardInterrupt")


def _json_usage_error(
    error: click.UsageError,
    frames_sent: int = 0,
    changes_sent: int = 0,
    extra: dict[str, Any] | None = None,
) -> None:
    """A usage error as the JSON error object every --json failure prints (on stderr), with
    the keys every result carries (``simulator``, ``url``) once the target is known."""
    command = error.ctx.command_path if error.ctx is not None else None
    usage = explain(UsageError(error.format_message()), "", frames_sent, changes_sent)
    failure = Failure(EXIT_BAD_ARGUMENT, usage.message, usage.hint, "UsageError", command)
    click.echo(json.dumps({**failure.as_json(), **(extra or {})}, ensure_ascii=False), err=True)


@click.group(cls=RobostarGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.option(
    "--port",
    "-p",
    envvar="ROBOSTAR_PORT",
    default=None,
    metavar="URL",
    help="The controller: /dev/ttyUSB0, serial://PATH?baudrate=N, tcp://HOST:PORT, or sim:// "
    "(the built-in simulator). Also from ROBOSTAR_PORT. Required (or --robot) for every "
    "command that talks to a controller.",
)
@click.option(
    "--robot",
    "-r",
    envvar="ROBOSTAR_ROBOT",
    default=None,
    metavar="NAME",
    help="A named controller from the profile file (see `robostar profiles`); --port overrides "
    "its port. Also from ROBOSTAR_ROBOT.",
)
@click.option(
    "--timeout",
    type=Finite(min=0.01, max=3600.0),
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
    port: str | None,
    robot: str | None,
    timeout: float | None,
    json_mode: bool,
    trace: str | None,
    channel: int,
    dry_run: bool,
) -> None:
    """robostar: the technician's console for a Robostar N1 controller.

    Every command that talks to a controller needs a target: --port (or ROBOSTAR_PORT) or a
    profile with --robot NAME; nothing picks one for you. --port sim:// is the built-in
    simulator, safe to try everything on. Exit codes: 0 done, 2 bad argument,
    3 refused by the controller (with its reason), 4 the line failed, 130 interrupted.

    \b
    Examples:
      robostar --port sim:// demo                  # a guided tour on the simulator
      robostar --port /dev/ttyUSB0 status
      robostar --robot cell1 status                # a profile from `robostar profiles`
      robostar --port tcp://127.0.0.1:9100 --json position --kind xy
      robostar --dry-run move 100 200 0 0          # show the frames, send nothing
    """
    session = ConsoleSession(Settings(port, timeout, json_mode, trace, channel, dry_run, robot))
    if isinstance(ctx.obj, ConsoleSession):
        # A line typed in `robostar shell`: it runs on the shell's open connection.
        session.share(ctx.obj)
    ctx.obj = session


def main(argv: Sequence[str] | None = None) -> None:
    """The console entry point."""
    cli.main(args=list(argv) if argv is not None else None, prog_name="robostar")
