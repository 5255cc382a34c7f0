"""``robostar jog``: the full-screen jog pad, and a timed jog for scripts.

The pad jogs only while a key is held. A terminal reports presses, not releases: a held key
sends one press and then, after the keyboard's autorepeat delay, a stream of repeats. So a
first press keeps the jog going for ``--hold`` seconds (just over the autorepeat delay), each
repeat for a short window more, and when the repeats stop the jog stops (the client's jog
context sends BG). Losing the terminal stops it too, and leaving always sends BG. The jog also
carries the hold deadline as its dead-man's switch: if this loop hangs (its screen output
blocked), the keepalive stops the jog by itself.
"""

from __future__ import annotations

import contextlib
import termios
import time
from contextlib import ExitStack
from dataclasses import dataclass, field

import click
from rich.console import Group, RenderableType
from rich.live import Live
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from robostar.cli.keys import KeyReader, TerminalLost
from robostar.cli.options import ControllerFile, Finite, common_options
from robostar.cli.reading import position_json, position_view
from robostar.cli.render import format_number, status_lamps
from robostar.cli.session import ConsoleSession, pass_session
from robostar.cli.teach import (
    GOTO_SPEED,
    Target,
    current_point,
    point_text,
    read_point,
    write_point,
)
from robostar.client.jog import Jog
from robostar.commands.control import EmergencyStop, ReadSpeed, SetSpeed
from robostar.commands.motion import JogContinue, JogStart, JogStop
from robostar.commands.status import ReadInfo, ReadPosition, ReadStatus
from robostar.errors import ControllerError, LineError, RobostarError, UsageError
from robostar.types import (
    ChannelStatus,
    JogDirection,
    MotionType,
    Point,
    Position,
    PositionKind,
    RobotType,
)

__all__ = [
    "AskGoto",
    "AskTeach",
    "Cancel",
    "ChangeSpeed",
    "Goto",
    "JogPad",
    "Quit",
    "StartJog",
    "StopJog",
    "StopMove",
    "Teach",
    "ToggleMotion",
    "jog",
]

SPEED_STEP = 50
REPEAT_HOLD = 0.2
"""How long one autorepeat keeps a jog going; autorepeat sends keys every 30-50 ms."""
DEADMAN_GRACE = 0.3
"""How long after the pad's own key-hold deadline the jog's keepalive lets go by itself. The
pad stops the jog at the deadline; the keepalive stops it only when the pad's loop is stuck
(a screen write blocked by Ctrl-S or a backed-up SSH session), so the two never race, and a
position read on a slow serial line (two exchanges at 9600 baud) does not cut a held jog."""
STALE_AFTER = 0.5
"""Keys that waited longer than this for a busy pad (a line that does not answer, a point read
or stored, a blocked screen) are dropped: the key was most likely let go long ago. Shorter
waits are a slow line's normal pace, and dropping their repeats would make a held jog stutter."""

_PLUS = {"right", "d", "l", "."}
_MINUS = {"left", "a", "h", ","}
_FASTER = {"up", "+", "="}
_SLOWER = {"down", "-", "_"}
_QUIT = {"q", "Q", "esc", "ctrl-c"}


@dataclass(frozen=True, slots=True)
class StartJog:
    axis: int
    direction: JogDirection


@dataclass(frozen=True, slots=True)
class StopJog:
    pass


@dataclass(frozen=True, slots=True)
class ChangeSpeed:
    speed: int


@dataclass(frozen=True, slots=True)
class ToggleMotion:
    motion: MotionType


@dataclass(frozen=True, slots=True)
class Quit:
    pass


@dataclass(frozen=True, slots=True)
class AskTeach:
    """Show the old and new value of ``point`` and ask before storing the position there."""

    point: int


@dataclass(frozen=True, slots=True)
class Teach:
    point: int


@dataclass(frozen=True, slots=True)
class AskGoto:
    """Show ``point`` and ask before moving there at low speed."""

    point: int


@dataclass(frozen=True, slots=True)
class Goto:
    point: int


@dataclass(frozen=True, slots=True)
class Cancel:
    """A typed point number or a question was abandoned."""


@dataclass(frozen=True, slots=True)
class StopMove:
    """Stop the pad's goto now: CF, the emergency stop (a move has no gentler stop)."""


Action = (
    StartJog
    | StopJog
    | StopMove
    | ChangeSpeed
    | ToggleMotion
    | Quit
    | AskTeach
    | Teach
    | AskGoto
    | Goto
    | Cancel
)


@dataclass
class JogPad:
    """The pad's logic, without a terminal or a clock: keys and ticks in, actions out."""

    axes: int
    speed: int
    hold: float = 0.55
    repeat_hold: float = REPEAT_HOLD
    axis: int = 1
    motion: MotionType = MotionType.JOINT
    jogging: JogDirection | None = None
    held_until: float = 0.0
    teaching: bool = False
    """Teach keys on: t stores the position into a point, g goes to one (``--teach FILE``)."""
    entry: str | None = None
    """"t" or "g" while a point number is typed; ``typed`` holds its digits."""
    typed: str = ""
    asking: AskTeach | AskGoto | None = None
    moving: bool = False
    """A goto runs (set by whoever started it): only space and the leave keys count, and
    they stop it; every other key is read and ignored, never kept for later."""
    _actions: list[Action] = field(default_factory=list)

    def key(self, name: str, now: float) -> list[Action]:
        """Take one key press (or autorepeat) at time ``now``."""
        self._actions = []
        if self.moving:
            if name == "space" or name in _QUIT:
                self.moving = False
                self._actions.append(StopMove())
            if name in _QUIT:
                self._actions.append(Quit())
        elif self.asking is not None:
            self._answer(name)
        elif self.entry is not None:
            self._type(name)
        elif self.teaching and name in ("t", "g"):
            self._stop()
            self.entry, self.typed = name, ""
        elif name in _PLUS or name in _MINUS:
            direction = JogDirection.PLUS if name in _PLUS else JogDirection.MINUS
            if self.jogging is direction:
                self.held_until = max(self.held_until, now + self.repeat_hold)
            else:
                self._stop()
                self.jogging = direction
                self.held_until = now + self.hold
                self._actions.append(StartJog(self.axis, direction))
        elif name.isdigit() and 1 <= int(name) <= self.axes:
            if int(name) != self.axis:
                self._stop()
                self.axis = int(name)
        elif name == "tab":
            self._stop()
            self.axis = self.axis % self.axes + 1
        elif name in _FASTER or name in _SLOWER:
            step = SPEED_STEP if name in _FASTER else -SPEED_STEP
            speed = min(1000, max(0, self.speed + step))
            if speed != self.speed:
                self.speed = speed
                self._actions.append(ChangeSpeed(speed))
        elif name == "m":
            self._stop()
            linear = self.motion is MotionType.JOINT
            self.motion = MotionType.LINEAR if linear else MotionType.JOINT
            self._actions.append(ToggleMotion(self.motion))
        elif name == "space":
            self._stop()
        elif name in _QUIT:
            self._stop()
            self._actions.append(Quit())
        return self._actions

    def _type(self, name: str) -> None:
        if name.isdigit() and len(self.typed) < 4:
            self.typed += name
        elif name == "backspace":
            self.typed = self.typed[:-1]
        elif name == "enter" and self.typed:
            number = int(self.typed)
            self.asking = AskTeach(number) if self.entry == "t" else AskGoto(number)
            self.entry, self.typed = None, ""
            self._actions.append(self.asking)
        elif name in ("esc", "q", "ctrl-c", "enter"):
            self.entry, self.typed = None, ""
            self._actions.append(Cancel())

    def _answer(self, name: str) -> None:
        asked, self.asking = self.asking, None
        if name in ("y", "Y") and asked is not None:
            self._actions.append(
                Teach(asked.point) if isinstance(asked, AskTeach) else Goto(asked.point)
            )
        else:
            self._actions.append(Cancel())

    def prompt(self) -> str:
        """What the pad is waiting for, when it waits for more than jog keys."""
        if self.entry is not None:
            what = "store the position into" if self.entry == "t" else "go to"
            return f"{what} point: {self.typed}_   (Enter: ok, Esc: cancel)"
        return ""

    def tick(self, now: float) -> list[Action]:
        """Stop a jog whose key is no longer held."""
        self._actions = []
        if self.jogging is not None and now >= self.held_until:
            self._stop()
        return self._actions

    def next_deadline(self) -> float | None:
        return self.held_until if self.jogging is not None else None

    def _stop(self) -> None:
        if self.jogging is not None:
            self.jogging = None
            self._actions.append(StopJog())


@dataclass
class _View:
    channel: int
    model: str
    position: Position | None = None
    status: ChannelStatus | None = None
    message: Text = field(default_factory=Text)
    line_ok: bool = True
    scara: bool = False
    target: str = ""
    """The session's banner (SIMULATOR or controller, the port): the full screen hides the
    one printed on stderr, and a simulator's pad must not pass for a robot's."""
    simulator: bool = False


_HELP = (
    "hold ←/→ jog −/+   1-6 or Tab pick the axis   ↑/↓ speed ±50   "
    "m joint/linear   space stop   q leave"
)


_TEACH_HELP = "t NUMBER Enter: store the position into that point   g NUMBER Enter: go there slowly"


def _render(pad: JogPad, view: _View) -> RenderableType:
    table = Table(box=None, pad_edge=False, expand=False)
    table.add_column("")
    table.add_column("axis")
    table.add_column("position", justify="right")
    table.add_column("")
    pos = view.position
    for axis in range(1, pad.axes + 1):
        chosen = axis == pad.axis
        value = format_number(pos[axis]) if pos is not None and axis <= len(pos.axes) else "-"
        state = ""
        if chosen and pad.jogging is not None:
            state = "jogging +" if pad.jogging is JogDirection.PLUS else "jogging -"
        table.add_row(
            "▶" if chosen else "",
            Text(f"axis {axis}", style="bold" if chosen else ""),
            value,
            Text(state, style="bold yellow"),
        )
    motion = "linear (XY)" if pad.motion is MotionType.LINEAR else "joint"
    head = Text(
        f"channel {view.channel} {view.model}   speed {pad.speed} ({pad.speed / 10:g} %)   "
        f"motion {motion}",
        style="bold",
    )
    parts: list[RenderableType] = [head, table]
    if view.status is not None:
        parts.append(status_lamps(view.status))
    if not view.line_ok:
        parts.append(Text("NO ANSWER FROM THE CONTROLLER", style="bold white on red"))
    parts.append(view.message)
    if pad.prompt():
        parts.append(Text(pad.prompt(), style="bold cyan"))
    parts.append(Text(_HELP, style="dim"))
    if pad.teaching:
        parts.append(Text(_TEACH_HELP, style="dim"))
    return Panel(Group(*parts), title=_title("robostar jog", view), border_style="cyan")


def _title(name: str, view: _View) -> Text:
    if not view.target:
        return Text(name)
    style = "bold magenta" if view.simulator else "bold"
    return Text.assemble(name, "  ", (view.target, style))


def _jog_direction(text: str) -> JogDirection:
    return JogDirection.PLUS if text in ("+", "plus") else JogDirection.MINUS


class _PadRunner:
    """Drives the pad: keys from the terminal, actions on the client, the screen refreshed."""

    def __init__(
        self,
        session: ConsoleSession,
        pad: JogPad,
        view: _View,
        poll: float,
        teach: str | None = None,
    ):
        self.session = session
        self.client = session.client
        self.pad = pad
        self.view = view
        self.poll = poll
        self.teach = teach
        self._jog = ExitStack()
        self._running: Jog | None = None
        """The jog in ``_jog``, if one runs."""
        self._goto: tuple[Target, int] | None = None
        """The goto that runs, and the channel speed to put back when it ends."""
        self._taught: Point | None = None
        self._last: tuple[float, ...] | None = None
        self._still = 0

    def apply(self, action: Action) -> bool:
        """Carry out one action; False when the pad should close."""
        channel = self.view.channel
        try:
            if isinstance(action, StartJog):
                direction = "+" if action.direction is JogDirection.PLUS else "-"
                # The dead-man's switch: the keepalive stops the jog by itself if this loop
                # hangs past the key-hold deadline (it cannot stop it while stuck).
                jog = self.client.jog(
                    channel,
                    action.axis,
                    action.direction,
                    motion=self.pad.motion,
                    held_until=self._hold_deadline,
                )
                self._running = self._jog.enter_context(jog)
                self.pad.jogging = action.direction  # it runs, whatever failed before it
                self.view.message = Text(f"jogging axis {action.axis} {direction}", "yellow")
            elif isinstance(action, StopJog):
                self._running = None
                self._jog.close()
                self.view.message = Text("stopped", "green")
            elif isinstance(action, ChangeSpeed):
                self.client.execute(SetSpeed(channel, action.speed))
                self.view.message = Text(f"speed {action.speed}")
            elif isinstance(action, StopMove):
                self._stop_goto()
            elif isinstance(action, ToggleMotion):
                self.view.message = Text(f"motion {action.motion.name.lower()}")
            elif isinstance(action, AskTeach | Teach | AskGoto | Goto | Cancel):
                self._teach(action)
            else:
                return False
        except ControllerError as error:
            self._drop_jog()
            reason = error.reason or error.describe
            self.view.message = Text(f"refused: {reason}", "bold red")
        except LineError as error:
            self._drop_jog()
            self.view.line_ok = False
            self.view.message = Text(f"line failed: {error}", "bold red")
        except RobostarError as error:
            # A jog whose keepalive failed has stopped on the controller: say so, carry on.
            self._drop_jog()
            self.view.message = Text(str(error), "bold red")
        return True

    def _drop_jog(self) -> None:
        """After an error: stop the jog that runs, if any, and say that none does.

        Closing the jog halts its keepalive before anything can fail, then sends BG; if that
        BG fails too, the controller stops the jog within 500 ms of the last BF. Errors are
        suppressed: the one being handled is what the pad shows."""
        self.pad.jogging = None
        self._running = None
        stack, self._jog = self._jog, ExitStack()
        with contextlib.suppress(Exception):
            stack.close()

    def _hold_deadline(self) -> float:
        return self.pad.held_until + DEADMAN_GRACE

    def lapsed(self) -> bool:
        """True (once) when the jog's keepalive let go because this loop fell behind the key
        hold: the pad then forgets that jog, and the keys that came meanwhile are stale."""
        jog = self._running
        if jog is None or not jog.expired or self.pad.jogging is None:
            return False
        self._drop_jog()  # BG once more; the keepalive already sent one
        self.view.message = Text(
            "the jog stopped: the pad fell behind the key (its screen output was blocked, "
            "or the line was slow); press the key again",
            "bold red",
        )
        return True

    def _teach(self, action: AskTeach | Teach | AskGoto | Goto | Cancel) -> None:
        channel = self.view.channel
        if isinstance(action, Cancel) or self.teach is None:
            self.view.message = Text("cancelled", "dim")
            return
        target = Target(action.point, self.teach)
        if isinstance(action, AskTeach):
            old = read_point(self.client, channel, target)
            self._taught = current_point(self.client, channel)
            self.view.message = Text(
                f"{target}: old {point_text(old)} -> new {point_text(self._taught)}. Store it? y/n",
                "bold yellow",
            )
        elif isinstance(action, Teach) and self._taught is not None:
            write_point(self.client, channel, target, self._taught)
            self.view.message = Text(f"stored {point_text(self._taught)} in {target}", "green")
            self._taught = None
        elif isinstance(action, AskGoto):
            point = read_point(self.client, channel, target)
            if point is None:
                self.pad.asking = None
                self.view.message = Text(f"{target} is empty: teach it first", "bold red")
                return
            self.view.message = Text(
                f"go to {target} {point_text(point)} at speed {GOTO_SPEED}? y/n", "bold yellow"
            )
        elif isinstance(action, Goto):
            point = read_point(self.client, channel, target)
            if point is not None:
                self._start_goto(target)

    def _start_goto(self, target: Target) -> None:
        """Start the move to ``target`` at GOTO_SPEED without waiting for it (as teach's goto
        does, but the loop keeps reading keys and redrawing): refresh() sees it arrive."""
        channel = self.view.channel
        before = self.client.speed(channel)
        self.client.set_speed(channel, GOTO_SPEED)
        try:
            self.client.move_to_point(channel, str(self.teach), target.number, motion="joint")
        except BaseException:
            with contextlib.suppress(RobostarError):
                self.client.set_speed(channel, before)
            raise
        self._goto = (target, before)
        self.pad.moving = True
        self.view.message = Text(
            f"moving to {target}...   space: stop now (emergency stop)", "bold yellow"
        )

    def _end_goto(self, message: Text) -> None:
        """The goto is over (arrived, stopped, failed): put the channel's speed back."""
        if self._goto is None:
            return
        before = self._goto[1]
        self._goto = None
        self.pad.moving = False
        self.view.message = message
        self.client.set_speed(self.view.channel, before)

    def _follow_goto(self, status: ChannelStatus) -> None:
        if self._goto is None or status.running:
            return
        target = self._goto[0]
        if status.alarm:
            self._end_goto(Text(f"the move to {target} stopped with an alarm", "bold red"))
        elif status.in_position:
            self._end_goto(Text(f"at {target}", "green"))

    def _stop_goto(self) -> None:
        """Space or a leave key during a goto: CF, the only stop a move has."""
        if self._goto is None:
            return
        try:
            self.client.execute(EmergencyStop())
        except BaseException:
            self.pad.moving = True  # still moving as far as we know: space tries again
            raise
        self._end_goto(
            Text(
                "stopped the move with an emergency stop (CF): clear its alarm with "
                "`robostar reset`",
                "bold red",
            )
        )

    def _stalled(self, position: Position) -> None:
        """A jog whose position stops changing has been stopped by the controller: say why."""
        if self.pad.jogging is None:
            self._last, self._still = None, 0
            return
        if self._last == position.axes:
            self._still += 1
        else:
            self._last, self._still = position.axes, 0
        if self._still == 2:
            why = "a soft limit"
            if self.view.scara and self.pad.motion is MotionType.JOINT and self.pad.axis == 2:
                near_zero = abs(position.axes[1]) < 1.0 if len(position.axes) > 1 else False
                if near_zero:
                    why = "the arm form would change (axis 2 crossing 0): jog it the other way"
            elif self.view.scara and self.pad.motion is MotionType.LINEAR:
                why = "a soft limit, or the arm form would change (the reach ends here)"
            self.view.message = Text(f"the jog stopped: {why}", "bold red")

    def refresh(self) -> None:
        channel = self.view.channel
        kind = PositionKind.XY if self.pad.motion is MotionType.LINEAR else PositionKind.ANGLE
        try:
            self.view.position = self.client.execute(ReadPosition(channel, kind))
            self.view.status = self.client.execute(ReadStatus())[channel - 1]
            self.view.line_ok = True
            self._stalled(self.view.position)
            self._follow_goto(self.view.status)
        except ControllerError as error:
            self.view.message = Text(f"refused: {error.reason or error.describe}", "bold red")
        except LineError:
            self.view.line_ok = False

    def run(self, reader: KeyReader) -> None:
        console = self.session.out.console
        next_poll = 0.0
        read_at = time.monotonic()
        with Live(console=console, screen=True, auto_refresh=False) as live:
            try:
                while True:
                    now = time.monotonic()
                    if now >= next_poll:
                        self.refresh()
                        next_poll = now + self.poll
                    live.update(_render(self.pad, self.view), refresh=True)
                    # Not during a goto: its keys are read as they come, and space stops it.
                    if not self.pad.moving and time.monotonic() - read_at > STALE_AFTER:
                        flush_input(reader)
                    wake = min(next_poll, self.pad.next_deadline() or next_poll)
                    try:
                        keys = reader.read(wake - time.monotonic())
                    except TerminalLost:
                        return
                    read_at = time.monotonic()
                    if self.lapsed():
                        keys = []  # typed while the pad was stuck: never replay them
                        flush_input(reader)
                    now = time.monotonic()
                    actions: list[Action] = []
                    for key in keys:
                        done = self.pad.key(key, now)
                        actions += done
                        if any(isinstance(a, AskTeach | Teach | AskGoto | Goto) for a in done):
                            # The rest was typed before the question (or the move) was on
                            # screen: it must not answer it, nor jog during the move.
                            break
                    actions += self.pad.tick(now)
                    if not all(self.apply(a) for a in actions):
                        return
                    if any(isinstance(a, AskTeach | Teach | AskGoto) for a in actions):
                        # Anything typed during a question's reads or a store was typed
                        # before the question or its outcome was on screen.
                        flush_input(reader)
            finally:
                self.close()

    def close(self) -> None:
        """Stop any jog and any goto, then send BG whatever state we think we are in."""
        try:
            self._jog.close()
        finally:
            try:
                self._stop_goto()
            finally:
                self.client.execute(JogStop(self.view.channel))


def flush_input(reader: KeyReader) -> None:
    """Drop the keys typed while the pad could not read them (a stall, a blocking action), so
    that a key let go long ago never jogs the robot."""
    if not reader.is_terminal():
        return
    # KeyReader (cli/keys.py) has no flush of its own; its descriptor is the one it reads.
    with contextlib.suppress(OSError, ValueError, termios.error):
        termios.tcflush(reader._fd, termios.TCIFLUSH)


@click.command()
@click.option(
    "--axis",
    type=click.IntRange(1, 6),
    default=1,
    show_default=True,
    help="The axis to jog (the pad starts on it).",
)
@click.option(
    "--direction",
    type=click.Choice(["+", "-", "plus", "minus"]),
    default=None,
    help="With --for: a timed jog in this direction, without the pad.",
)
@click.option(
    "--for",
    "seconds",
    type=Finite(0.0, 60.0),
    default=None,
    metavar="SECONDS",
    help="Jog for this long, then stop (no terminal needed).",
)
@click.option(
    "--speed",
    type=click.IntRange(0, 1000),
    default=None,
    help="Set the channel's speed (0-1000) first.",
)
@click.option("--linear", is_flag=True, help="Jog along X/Y/Z (LMOV) instead of one joint.")
@click.option(
    "--hold",
    type=Finite(0.1, 2.0),
    default=0.55,
    show_default=True,
    metavar="SECONDS",
    help="How long a first key press jogs before autorepeat takes over; set it just "
    "above your keyboard's repeat delay.",
)
@click.option(
    "--poll",
    type=Finite(0.05, 5.0),
    default=0.2,
    show_default=True,
    metavar="SECONDS",
    help="How often the pad reads the position.",
)
@click.option(
    "--teach",
    "teach_file",
    type=ControllerFile("PNT"),
    default=None,
    metavar="FILE.PNT",
    help="Teach keys in the pad: t stores the position into a point of FILE.PNT (asks first), "
    "g goes to a point at low speed (asks first).",
)
@common_options(channel=True)
@pass_session
def jog(
    session: ConsoleSession,
    axis: int,
    direction: str | None,
    seconds: float | None,
    speed: int | None,
    linear: bool,
    hold: float,
    poll: float,
    teach_file: str | None,
) -> None:
    """Jog the robot from a full-screen pad: it moves only while you hold a key.

    Hold → or ← to jog the chosen axis + or −; 1-6 or Tab pick the axis; ↑/↓ change the speed;
    m switches joint/linear; q leaves. Releasing the key, losing the terminal or leaving
    always stops the jog (BG). With --direction and --for it makes one timed jog instead,
    which needs no terminal.

    \b
    Example:
      robostar --port sim:// jog
      robostar --port sim:// jog --teach DEMO.PNT
      robostar --port sim:// jog --axis 3 --direction + --for 0.5
    """
    channel = session.channel
    motion = MotionType.LINEAR if linear else MotionType.JOINT
    if (direction is None) != (seconds is None):
        raise UsageError("a timed jog needs both --direction and --for")
    if direction is not None and seconds is not None:
        _timed(session, axis, _jog_direction(direction), seconds, speed, motion)
        return
    if session.dry_run:
        session.plan(
            [
                JogStart(channel, axis, JogDirection.PLUS, motion),
                JogContinue(channel),
                JogStop(channel),
            ],
            note="The pad sends BE when a key goes down, BF every 200 ms while it is held, "
            "and BG when it is released.",
        )
    reader = KeyReader()
    if not reader.is_terminal():
        raise UsageError(
            "the jog pad needs a terminal; for a jog from a script use --direction and --for"
        )
    if speed is not None:
        session.send(SetSpeed(channel, speed))
    info = session.send(ReadInfo()).channel(channel)
    axes = len(info.axes_in_use) or 6
    current_speed = session.send(ReadSpeed(channel))
    pad = JogPad(axes=axes, speed=current_speed, hold=hold, axis=min(axis, axes), motion=motion)
    pad.teaching = teach_file is not None
    view = _View(
        channel,
        info.model,
        scara=info.robot_type is RobotType.SCARA,
        target=session.banner(),
        simulator=session.simulator,
    )
    session.announce(f"Jog pad on channel {channel}: the robot moves while you hold a key.")
    runner = _PadRunner(session, pad, view, poll, teach_file)
    with reader.cbreak():
        runner.run(reader)
    pos = session.send(ReadPosition(channel, PositionKind.XY))
    session.out.result(
        {"ok": True, "channel": channel, "position": position_json(channel, pos)},
        lambda: Group(Text("Jog pad closed; jog stopped."), position_view(channel, pos)),
    )


def _timed(
    session: ConsoleSession,
    axis: int,
    direction: JogDirection,
    seconds: float,
    speed: int | None,
    motion: MotionType,
) -> None:
    channel = session.channel
    if session.dry_run:
        session.plan(
            [JogStart(channel, axis, direction, motion), JogContinue(channel), JogStop(channel)],
            note=f"BF repeats every 200 ms for {seconds:g} s, then BG.",
        )
    if speed is not None:
        session.send(SetSpeed(channel, speed))
    sign = "+" if direction is JogDirection.PLUS else "-"
    session.announce(f"Channel {channel} axis {axis} will jog {sign} for {seconds:g} s.")
    with session.client.jog(channel, axis, direction, motion=motion):
        time.sleep(seconds)
    session.client.wait_stopped(channel, 30.0)
    pos = session.send(ReadPosition(channel, PositionKind.ANGLE))
    session.out.result(
        {
            "ok": True,
            "channel": channel,
            "axis": axis,
            "direction": sign,
            "seconds": seconds,
            "position": position_json(channel, pos),
        },
        lambda: Group(
            Text(f"Jogged axis {axis} {sign} for {seconds:g} s."), position_view(channel, pos)
        ),
    )
