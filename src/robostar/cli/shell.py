"""``robostar shell``: one connection held open, every command at a prompt.

Each line is a robostar command line without the program name (``status``, ``servo on``,
``files ls -c 2``); it runs on the shell's connection, so nothing reopens the port. At a
terminal the prompt (prompt_toolkit) completes commands, channels, file names and point numbers,
keeps its history in the user's data folder, and shows a status line: servo, alarm, job, and
SIMULATOR when the target is one. ``watch`` is the live view (``monitor``); ``jog`` and
``teach`` work as on the command line. Without a terminal, lines are read from standard input.
"""

from __future__ import annotations

import itertools
import os
import shlex
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from robostar.cli.failures import EXIT_BAD_ARGUMENT
from robostar.cli.options import common_options
from robostar.cli.session import ConsoleSession, pass_session
from robostar.errors import RobostarError

if TYPE_CHECKING:
    from prompt_toolkit.completion import CompleteEvent, Completion
    from prompt_toolkit.document import Document

__all__ = ["HISTORY_ENV", "ShellState", "history_path", "run_line", "shell", "split_line"]

HISTORY_ENV = "ROBOSTAR_HISTORY"
_LEAVE = {"exit", "quit", "q"}
_ALIASES = {"watch": ["monitor"]}
STATUS_EVERY = 1.0
"""Seconds between status-line reads (AA, EF, AB): the toolbar is redrawn on every key."""


def history_path() -> Path:
    """``$ROBOSTAR_HISTORY``, else ``shell_history`` in the user's data folder."""
    override = os.environ.get(HISTORY_ENV)
    if override:
        return Path(override)
    import platformdirs

    return Path(platformdirs.user_data_dir("robostar")) / "shell_history"


def split_line(line: str) -> list[str]:
    """A typed line as arguments; aliases (``watch``) expanded. UsageError on bad quoting."""
    try:
        words = shlex.split(line, comments=True)
    except ValueError as error:
        raise click.UsageError(f"cannot read the line: {error}") from None
    if words and words[0] in _ALIASES:
        words = _ALIASES[words[0]] + words[1:]
    return words


_NOT_IN_SHELL = {
    "shell": "Already in the shell.",
    "serve": "`robostar serve` owns lines and runs until stopped: start it outside the shell.",
}
"""Commands the shell refuses (and does not complete), with the reason."""


def _serial_doctor(parent: ConsoleSession, words: list[str]) -> str | None:
    """`doctor` on a serial line probes the port's baud rates with a connection of its own,
    which the shell's open connection keeps busy: it would blame "another program", the shell
    itself. Say so instead (on any other line doctor runs on the shell's connection)."""
    if words[0] != "doctor" or any(w in ("--help", "-h") for w in words):
        return None
    from robostar.transport.url import Kind, parse_url

    try:
        kind = parse_url(parent.port).kind
    except (RobostarError, ValueError):
        return None
    if kind not in (Kind.SERIAL, Kind.PYSERIAL_URL):
        return None
    return (
        f"`doctor` probes {parent.port} with a connection of its own, and this shell holds the "
        "port open: leave the shell (exit) and run `robostar doctor` there. The shell's "
        "connection works: `status` and `info` check it here."
    )


def run_line(parent: ConsoleSession, words: list[str]) -> int:
    """Run one command line on the shell's connection; its exit code."""
    from robostar.cli.app import cli

    refusal = _NOT_IN_SHELL.get(words[0]) if words else None
    if refusal is None and words:
        refusal = _serial_doctor(parent, words)
    if refusal is not None:
        click.echo(refusal, err=True)
        return EXIT_BAD_ARGUMENT
    try:
        code = cli.main(args=words, prog_name="robostar", standalone_mode=False, obj=parent)
    except click.exceptions.Abort:
        click.echo("Aborted.", err=True)
        return 1
    except click.ClickException as error:
        error.show()
        return error.exit_code
    finally:
        parent.end_line()
    return code if isinstance(code, int) else 0


class ShellState:
    """What the prompt shows and completes, read from the controller and cached."""

    def __init__(self, session: ConsoleSession):
        self.session = session
        self._status_at = 0.0
        self._status = ""
        self._files: dict[int, list[str]] = {}
        self._points: dict[tuple[int, str], list[str]] = {}

    def forget(self) -> None:
        """After a command: the files, points and status may have changed."""
        self._files.clear()
        self._points.clear()
        self._status_at = 0.0

    def status_line(self) -> str:
        now = time.monotonic()
        if now - self._status_at >= STATUS_EVERY:
            self._status_at = now
            self._status = self._read_status()
        return self._status

    def _read_status(self) -> str:
        session = self.session
        channel = session.channel
        head = "SIMULATOR " if session.simulator else ""
        robot = f" robot {session.profile.name}" if session.profile else ""
        try:
            client = session.client
            status = client.status()[channel - 1]
            job = client.job_name(channel)
            alarms = client.alarms()
        except RobostarError as error:
            return f"{head}{session.port}{robot} | ch {channel} | no answer: {error}"
        servo = "servo ON" if status.servo_on else "servo off"
        alarm = f"ALARM {alarms[0]}" if alarms else ("ALARM" if status.alarm else "no alarm")
        state = "running" if status.running else "stopped"
        return (
            f"{head}{session.port}{robot} | ch {channel} | {servo} | {alarm} | "
            f"job {job or '-'} {state}"
        )

    def files(self, channel: int) -> list[str]:
        if channel not in self._files:
            try:
                records = self.session.client.list_files(channel)
            except RobostarError:
                return []
            self._files[channel] = [r.name for r in records]
        return self._files[channel]

    def points(self, channel: int, name: str) -> list[str]:
        key = (channel, name.upper())
        if key not in self._points:
            try:
                points = self.session.client.download_points(channel, name).points
            except RobostarError:
                return []
            self._points[key] = [str(n) for n in sorted(points)]
        return self._points[key]


def _commands() -> list[str]:
    from robostar.cli.app import SUBCOMMANDS

    offered = [name for name in SUBCOMMANDS if name not in _NOT_IN_SHELL]
    return sorted([*offered, *_ALIASES, "exit"])


def _subcommands(name: str) -> list[str]:
    from robostar.cli.app import cli

    ctx = click.Context(cli)
    command = cli.get_command(ctx, name)
    if isinstance(command, click.Group):
        return sorted(command.list_commands(ctx))
    return []


def candidates(state: ShellState, words: list[str], current: str) -> Iterable[str]:
    """What may come next after ``words`` (the finished words of the line)."""
    if not words:
        return _commands()
    previous = words[-1]
    if previous in ("-c", "--channel"):
        return ["1", "2", "3"]
    channel = _channel_of(words, state.session.channel)
    if previous.upper().endswith(".PNT"):
        return state.points(channel, previous)
    if len(words) == 1:
        subs = _subcommands(words[0])
        if subs:
            return subs
    if current.startswith("-"):
        return []
    wants_file = words[0] in ("move-point", "files", "job", "teach")
    return state.files(channel) if wants_file else []


def _channel_of(words: list[str], default: int) -> int:
    for flag, value in itertools.pairwise(words):
        if flag in ("-c", "--channel") and value in ("1", "2", "3"):
            return int(value)
    return default


def _completer(state: ShellState) -> Any:
    from prompt_toolkit.completion import Completer, Completion

    class ShellCompleter(Completer):
        def get_completions(
            self, document: Document, complete_event: CompleteEvent
        ) -> Iterator[Completion]:
            text = document.text_before_cursor
            try:
                words = shlex.split(text)
            except ValueError:
                return
            current = "" if not text or text[-1].isspace() else (words.pop() if words else "")
            for word in candidates(state, words, current):
                if word.upper().startswith(current.upper()):
                    yield Completion(word, start_position=-len(current))

    return ShellCompleter()


def _terminal_lines(state: ShellState) -> Iterator[str]:
    from prompt_toolkit import PromptSession
    from prompt_toolkit.history import FileHistory

    path = history_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    prompt: PromptSession[str] = PromptSession(
        history=FileHistory(str(path)),
        completer=_completer(state),
        complete_while_typing=False,
        bottom_toolbar=state.status_line,
        refresh_interval=STATUS_EVERY,
    )
    while True:
        try:
            yield prompt.prompt(_prompt_text(state.session))
        except KeyboardInterrupt:
            continue
        except EOFError:
            return


def _prompt_text(session: ConsoleSession) -> str:
    where = "SIMULATOR" if session.simulator else session.port
    return f"robostar [{where}] ch{session.channel}> "


def _piped_lines(stream: Any) -> Iterator[str]:
    for line in stream:
        yield line.rstrip("\n")


@click.command()
@common_options(channel=True)
@pass_session
def shell(session: ConsoleSession) -> None:
    """An interactive console on one open connection: type commands without `robostar`.

    Tab completes commands, channels, file names and point numbers; ↑ recalls history; the
    bottom line shows servo, alarm, job and SIMULATOR. `watch` is the live view, `jog` and
    `teach` work as usual, `exit` (or Ctrl-D) leaves. Without a terminal, it reads one command
    per line from standard input.

    \b
    Example:
      robostar --port sim:// shell
      robostar --robot cell1 shell
      printf 'status\\nservo on\\n' | robostar --port sim:// shell
    """
    if session.dry_run:
        raise click.UsageError("--dry-run: give it per line inside the shell instead")
    session.client  # noqa: B018  (opened once, here: every line runs on it)
    state = ShellState(session)
    interactive = sys.stdin.isatty() and sys.stdout.isatty() and not session.out.json
    if interactive:
        session.out.note(f"Connected to {session.banner()}. Type help, or exit to leave.")
    lines: Callable[[], Iterator[str]] = (
        (lambda: _terminal_lines(state)) if interactive else (lambda: _piped_lines(sys.stdin))
    )
    worst = 0
    for line in lines():
        try:
            words = split_line(line)
        except click.UsageError as error:
            error.show()
            worst = max(worst, EXIT_BAD_ARGUMENT)  # a line not run is a failure of the script
            continue
        if not words:
            continue
        if words[0] in _LEAVE:
            break
        if words[0] == "help":
            words = ["--help"]
        code = run_line(session, words)
        worst = max(worst, code)  # the worst is the highest: 2 < 3 refused < 4 line < 130
        state.forget()
    if not interactive and worst:
        raise click.exceptions.Exit(worst)
