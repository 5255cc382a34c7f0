"""One run of the command: the global options, the client (opened on first use) and dry runs."""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import IO, TYPE_CHECKING, Any, TypeVar

import click
from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from robostar.cli.annotate import describe_request
from robostar.cli.profiles import Profile
from robostar.cli.profiles import profile as load_profile
from robostar.cli.render import Output
from robostar.commands import Command
from robostar.errors import UsageError
from robostar.protocol.frame import encode_packet

if TYPE_CHECKING:
    from robostar.client import Client
    from robostar.client.trace import TraceRecord
    from robostar.types import Alarm

__all__ = ["ConsoleSession", "DryRunDone", "PlannedFrame", "Settings", "pass_session"]

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class Settings:
    """The global options."""

    port: str | None
    timeout: float | None
    json: bool
    trace: str | None
    channel: int
    dry_run: bool
    robot: str | None = None


@dataclass(frozen=True, slots=True)
class PlannedFrame:
    """A frame a dry run would send, with what it means."""

    frame: bytes
    meaning: str


class DryRunDone(Exception):
    """Raised after a dry run has printed its frames, to end the command without sending."""


NO_TARGET = (
    "no controller given: name one with --port URL (or the ROBOSTAR_PORT variable), or a "
    "profile with --robot NAME (see `robostar profiles`); --port sim:// is the built-in simulator"
)


def describe_url(port: str) -> str:
    """``port`` with the TCP port a ``tcp://host`` URL will use said aloud."""
    from urllib.parse import urlsplit

    from robostar.transport.url import DEFAULT_TCP_PORT

    if not port.lower().startswith("tcp://"):
        return port
    try:
        given = urlsplit(port).port
    except ValueError:
        return port
    return port if given is not None else f"{port} (default port {DEFAULT_TCP_PORT})"


def is_simulator(port: str) -> bool:
    """True for the built-in simulator's URLs."""
    return port.strip().lower().startswith("sim:")


class ConsoleSession:
    """Shared by every command of one run; ``ctx.obj`` of the root group."""

    def __init__(self, settings: Settings):
        self.settings = settings
        self.out = Output(settings.json)
        self._client: Client | None = None
        self._client_options: dict[str, Any] = {}
        self._profile: Profile | None = None
        self._resolved = False
        self._trace_file: IO[str] | None = None
        self.frames_sent = 0
        """Frames this run wrote to the line: error messages never claim nothing was sent."""
        self.changes_sent = 0
        """Requests this run sent that change the controller (CHANGES_STATE)."""
        self.alarms_left: tuple[Alarm, ...] = ()
        self._shared = False
        self._served_simulator = False
        self._child: ConsoleSession | None = None
        self._motion: tuple[str, int] | None = None
        self._stop_sent: str | None = None
        """The stop (BG, CI, CD, CF) this run sent after the motion it started, if any."""
        self._in_flight: _InFlight | None = None
        self.upload_total: int | None = None
        """How many lines the upload in progress has (set by the command that knows)."""
        self.stopped_on_interrupt = ""
        """What Ctrl-C stopped (a motion this run started), for the message."""
        self.interrupt_note = ""
        """What Ctrl-C cut short (set by the command, or from the request on the line)."""

    @property
    def profile(self) -> Profile | None:
        """The profile named by --robot (read on first use)."""
        self._resolve()
        return self._profile

    @property
    def port(self) -> str:
        """The controller's URL: --port, ROBOSTAR_PORT, or the profile's; an error when none."""
        self._resolve()
        port = self.settings.port or (self._profile.port if self._profile else None)
        if not port:
            raise click.UsageError(NO_TARGET)
        return port

    @property
    def port_label(self) -> str:
        """The URL for messages (with the TCP port used when the URL gave none), ``"(no port)"``
        when none was given."""
        try:
            return describe_url(self.port)
        except click.UsageError:
            return "(no port)"

    @property
    def simulator(self) -> bool:
        """``sim://``, or a served simulator that said so when asked (AD)."""
        return self._served_simulator or is_simulator(self.port_label)

    def banner(self) -> str:
        """Which controller this run talks to: SIMULATOR when it is one, and the profile."""
        port = self.port_label
        parts = ["SIMULATOR" if self.simulator else "controller", port]
        if self._profile is not None:
            parts.append(f"robot {self._profile.name}")
        return " | ".join(parts)

    def _resolve(self) -> None:
        if self._resolved:
            return
        self._resolved = True
        if self.settings.robot:
            self._profile = load_profile(self.settings.robot)
        self._mark_output()

    def _mark_output(self) -> None:
        port = self.settings.port or (self._profile.port if self._profile else None)
        if port:
            # Every JSON result and error says what it came from. Only sim:// is known from its
            # URL; any other target is null ("not known") until _identify has asked it (AD),
            # so an error before that never calls a served simulator a controller.
            known = self.out.extra.get("simulator") is True  # `demo` runs its own simulator
            if known or is_simulator(port) or self._served_simulator:
                self.out.extra["simulator"] = True
            else:
                self.out.extra.setdefault("simulator", None)
            self.out.extra.setdefault("url", port)
        if self._profile is not None:
            self.out.extra["robot"] = self._profile.name

    @property
    def channel(self) -> int:
        return self.settings.channel

    @property
    def dry_run(self) -> bool:
        return self.settings.dry_run

    def set_json(self, on: bool) -> None:
        """``--json`` given after the command name."""
        if on and not self.settings.json:
            self.settings = replace(self.settings, json=True)
            extra = self.out.extra
            self.out = Output(True)
            self.out.extra.update(extra)

    def set_channel(self, channel: int) -> None:
        """``--channel`` given after the command name."""
        self.settings = replace(self.settings, channel=channel)

    def client_options(self, **options: Any) -> None:
        """Extra options for the client (``reconnect``, a default timeout), before it opens."""
        if self._client is not None:
            raise RuntimeError("the client is already open")
        self._client_options.update(options)

    @property
    def client(self) -> Client:
        """The client, opened on first use so that offline commands never touch a port."""
        if self._client is None:
            # Imported here: `decode` and `raw --dry-run` run without opening any transport.
            from robostar.client import Client

            port = self.port
            options: dict[str, Any] = {}
            if self._profile is not None:
                if self._profile.timeout is not None:
                    options["timeout"] = self._profile.timeout
                if self._profile.baud is not None and not is_simulator(port):
                    options["baudrate"] = self._profile.baud
            options.update(self._client_options)
            if self.settings.timeout is not None:
                options["timeout"] = self.settings.timeout
            if self.settings.trace:
                self._trace_file = _open_trace(self.settings.trace)
            options["trace"] = self._on_frame
            # Any target but sim:// may be a simulator: `robostar sim` serves TCP (on another
            # machine too, with --allow-remote), pseudo-terminals, a serial port through a
            # null-modem cable, and the line server passes its answers on. AD says which.
            maybe_served = not is_simulator(port)
            if not maybe_served:
                self._banner()  # SIMULATOR or controller, before anything is sent
            try:
                client = Client(port, **options)
            except BaseException:
                if maybe_served and (self._profile is not None or describe_url(port) != port):
                    self._banner()  # the target the error's URL does not spell out
                raise
            self._client = client
            if maybe_served:
                # The banner waits for the answer: a served simulator must not pass for a robot.
                self._identify(client)
                self._banner()
        return self._client

    def _banner(self) -> None:
        if not self.settings.json:
            self.out.note(self.banner(), style="bold magenta" if self.simulator else "dim")

    def _identify(self, client: Client) -> None:
        """Ask the target what it is (AD): a simulator must never pass for a robot, wherever
        it is served. The read is not counted as sent."""
        from robostar.commands.identity import is_simulator_identity
        from robostar.commands.status import ReadInfo
        from robostar.errors import RobostarError

        counted = self.frames_sent
        try:
            info = client.execute(ReadInfo())
        except RobostarError:
            return  # the command itself will meet and report the trouble ("simulator": null)
        finally:
            self.frames_sent = counted
        # Whatever name and version its configuration gives, a simulator's AD says so.
        self._served_simulator = is_simulator_identity(info)
        self.out.extra["simulator"] = self._served_simulator

    def read_alarms_left(self) -> None:
        """Read the controller's current alarms (AB) after a refusal into ``alarms_left``;
        none if that fails or no connection is open (never opened just to look)."""
        if self._client is None or self.dry_run:
            return
        from robostar.commands.status import ReadAlarms
        from robostar.errors import RobostarError

        with contextlib.suppress(RobostarError):
            self.alarms_left = self._client.execute(ReadAlarms())

    def share(self, parent: ConsoleSession) -> None:
        """Run on ``parent``'s connection (the shell's): same target, same open client, which
        this session never closes; frames it sends are counted here too."""
        if self.settings.trace:
            raise click.UsageError("--trace: give it to `robostar shell` itself, for every line")
        if self.settings.port or self.settings.robot:
            raise click.UsageError(
                f"the shell is connected to {parent.port}; leave it (exit) to change --port/--robot"
            )
        self._profile = parent.profile
        self.settings = replace(self.settings, port=parent.port)
        self._resolved = False
        self._resolve()
        self._client = parent.client
        self._shared = True
        self._served_simulator = parent.simulator and not is_simulator(parent.port)
        # What the shell knows of its target (true, false once asked, or null).
        self.out.extra["simulator"] = parent.out.extra.get("simulator")
        parent._child = self

    def stop_started_motion(self) -> None:
        """After Ctrl-C: stop a motion this run started and that is still going (CI for homing,
        CD for a job, BG for a jog, CF for a move, which has no gentler stop)."""
        if self._motion is None or self._client is None:
            return
        code, channel = self._motion
        words = {
            "CI": f"stopped the homing of channel {channel} (CI)",
            "CD": f"stopped the job of channel {channel} (CD)",
            "BG": f"stopped the jog of channel {channel} (BG)",
            "CF": f"stopped the move of channel {channel} with an emergency stop (CF): "
            "clear its alarm with `robostar reset`",
        }
        if self._stop_sent is not None:
            # The command stopped it on its way out (a jog sends BG when it ends).
            self.stopped_on_interrupt = words[self._stop_sent].replace(
                f"({self._stop_sent})", f"({self._stop_sent} sent)"
            )
            return
        from robostar.commands.control import EmergencyStop, StopHoming, StopJob
        from robostar.commands.motion import JogStop
        from robostar.commands.status import ReadStatus
        from robostar.errors import RobostarError

        try:
            status = self._client.execute(ReadStatus())[channel - 1]
            if not status.running and status.in_position:
                return
            stop = _STOPS[code]
            command = {
                "CI": StopHoming(channel),
                "CD": StopJob(channel),
                "BG": JogStop(channel),
                "CF": EmergencyStop(),
            }[stop]
            self._client.execute(command)
        except (RobostarError, KeyboardInterrupt):
            self.stopped_on_interrupt = f"could not stop the {code} motion: check the robot"
            return
        self.stopped_on_interrupt = words[stop]

    def interrupted_during(self) -> str:
        """After Ctrl-C: the request that was on the line and what is known of it ("" when
        none was): an upload cut short, a state change whose outcome is unknown, a read."""
        flight = self._in_flight
        if flight is None or flight.done:
            return ""
        if flight.code == "FB":
            of = f"/{self.upload_total}" if self.upload_total is not None else ""
            name = f" {flight.file}" if flight.file else ""
            return (
                f"FB{name} aborted after {flight.lines}{of} lines; "
                "the file on the controller may be missing or old"
            )
        if _changes_state(flight.code):
            return f"the outcome of {flight.code} is unknown; check it (`robostar status`)"
        if self._motion is not None:
            return ""  # a read while a motion runs: the stop says what matters
        return f"{flight.code} (a read) was cut short; it changes nothing on the controller"

    def end_line(self) -> None:
        """A shell line's session is done: its frames are no longer counted there."""
        self._child = None

    def _on_frame(self, record: TraceRecord) -> None:
        if self._child is not None:
            self._child._on_frame(record)
        self._follow(record)
        if record.direction == "tx":
            self.frames_sent += 1
            if record.kind == "request" and _changes_state(record.command):
                self.changes_sent += 1
            if record.kind == "request" and record.command in _STOPS:
                channel = (record.fields or {}).get("channel", self.channel)
                self._stop_sent = None
                self._motion = (record.command, int(channel))
            elif (
                record.kind == "request"
                and self._motion is not None
                and record.command == _STOPS[self._motion[0]]
            ):
                self._stop_sent = record.command
        if self._trace_file is not None:
            self._trace_file.write(record.to_json() + "\n")

    def _follow(self, record: TraceRecord) -> None:
        """Keep track of the request on the line, for the message after Ctrl-C."""
        if record.direction == "tx" and record.kind == "request" and record.command:
            fields = record.fields or {}
            file = fields.get("file")
            self._in_flight = _InFlight(record.command, str(file) if file else "")
            return
        flight = self._in_flight
        if flight is None or flight.done or record.command != flight.code:
            return
        if record.direction == "tx":
            if record.kind == "upload line":
                flight.line_pending = True
            elif record.kind == "upload end":
                flight.ended = True
            return
        if record.kind != "answer":
            return
        flag = record.flag or ""
        if flag in ("0x31", "0x32", "0x33", "0x34"):
            flight.done = True
            return
        shape = _shape(flight.code)
        if shape == "upload":
            if flight.ended:
                flight.done = True
            elif flight.line_pending:
                flight.lines += 1
                flight.line_pending = False
        elif shape == "two-phase":
            flight.answers += 1
            flight.done = flight.answers >= 2
        elif shape != "multi":
            flight.done = True

    def close(self) -> None:
        try:
            if self._client is not None:
                client, self._client = self._client, None
                if not self._shared:
                    client.close()
        finally:
            if self._trace_file is not None:
                trace, self._trace_file = self._trace_file, None
                trace.close()

    def send(self, command: Command[T]) -> T:
        """Run ``command`` on the controller; in a dry run, print its frame and stop."""
        if self.dry_run:
            self.plan([command])
        return self.client.execute(command)

    def plan(self, frames: Sequence[Command[Any] | PlannedFrame], note: str = "") -> None:
        """Print the frames a command would send, then end the run (dry run only)."""
        planned = [
            f
            if isinstance(f, PlannedFrame)
            else PlannedFrame(encode_packet(f.encode()), describe_request(f.encode()))
            for f in frames
        ]
        rows = [{"hex": p.frame.hex(" "), "meaning": p.meaning} for p in planned]
        self.out.result(
            {"dry_run": True, "port": self.port_label, "frames": rows, "note": note},
            lambda: _plan_table(
                planned,
                note,
                f"{self.port_label} (SIMULATOR)" if self.simulator else self.port_label,
            ),
        )
        raise DryRunDone

    def announce(self, text: str) -> None:
        """Say what is about to move, before it does (not in a dry run, where nothing moves)."""
        if not self.dry_run:
            self.out.warn(text)


@dataclass(slots=True)
class _InFlight:
    """The request on the line, as the wire trace shows it."""

    code: str
    file: str = ""
    lines: int = 0
    """FB lines the controller accepted."""
    line_pending: bool = False
    ended: bool = False
    answers: int = 0
    done: bool = False


def _shape(code: str) -> str:
    from robostar.commands import COMMANDS

    classes = COMMANDS.get(code, ())
    return classes[0].SHAPE.value if classes else "single"


_STOPS = {"BA": "CI", "CC": "CD", "BE": "BG", "BF": "BG", "BB": "CF", "BC": "CF", "BD": "CF"}
"""The stop for each motion a run may start (a move has only the emergency stop)."""


def _changes_state(code: str | None) -> bool:
    from robostar.commands import COMMANDS

    return any(c.CHANGES_STATE for c in COMMANDS.get(code or "", ()))


def _open_trace(path: str) -> IO[str]:
    try:
        return open(path, "a", encoding="utf-8", buffering=1)
    except OSError as error:
        raise UsageError(f"trace: cannot open {path!r}: {error}") from error


def _plan_table(planned: Sequence[PlannedFrame], note: str, port: str) -> RenderableType:
    table = Table(title=f"Dry run: frames that would be sent to {port}", title_justify="left")
    table.add_column("#", justify="right")
    table.add_column("frame (hex)")
    table.add_column("meaning")
    for i, p in enumerate(planned, 1):
        table.add_row(str(i), p.frame.hex(" "), Text(p.meaning))
    parts: list[RenderableType] = [table]
    if note:
        parts.append(Text(note, style="dim"))
    parts.append(Text("Nothing was sent.", style="dim"))
    return Group(*parts)


pass_session = click.make_pass_decorator(ConsoleSession)
