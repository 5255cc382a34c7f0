"""``robostar monitor``: a live view of every channel, refreshed at a chosen rate.

Status bits as lamps, positions, speed, running job and step, current alarms and I/O lamps.
When the line stops answering the view says so at once, in red, with the time of the last good
answer, and keeps trying; the last values stay on screen, dimmed.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from functools import partial
from typing import Any

import click
from rich.console import Group, RenderableType
from rich.live import Live
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from robostar.cli.keys import KeyReader, TerminalLost
from robostar.cli.options import Finite, common_options
from robostar.cli.render import STATUS_BITS, jsonable, lamps_table
from robostar.cli.session import ConsoleSession, pass_session
from robostar.commands.control import ReadSpeed
from robostar.commands.io import ReadInputs, ReadOutputs
from robostar.commands.job import ReadJobName, ReadJobStep
from robostar.commands.status import ReadAlarms, ReadInfo, ReadPosition, ReadStatus
from robostar.errors import ControllerError, LineError, ProtocolError, UsageError
from robostar.types import Alarm, ChannelStatus, ControllerInfo, Position, PositionKind

__all__ = ["ChannelSample", "Sample", "Sampler", "monitor", "render_sample"]

MONITOR_TIMEOUT = 1.0
"""Reply timeout when none is given: a dead line shows within a couple of seconds."""


@dataclass(frozen=True, slots=True)
class ChannelSample:
    channel: int
    model: str
    status: ChannelStatus
    position: Position | None
    speed: int | None
    job: str | None
    step: int | None


@dataclass(frozen=True, slots=True)
class Sample:
    """One refresh: everything read, or the error that stopped the reading."""

    time: float
    channels: tuple[ChannelSample, ...] = ()
    alarms: tuple[Alarm, ...] = ()
    inputs: tuple[tuple[int, tuple[bool, ...]], ...] = ()
    outputs: tuple[tuple[int, tuple[bool, ...]], ...] = ()
    error: str | None = None

    def as_json(self) -> dict[str, Any]:
        return {
            "time": self.time,
            "line_ok": self.error is None,
            "error": self.error,
            "channels": jsonable(self.channels),
            "alarms": jsonable(self.alarms),
            "inputs": {str(p): [int(c) for c in contacts] for p, contacts in self.inputs},
            "outputs": {str(p): [int(c) for c in contacts] for p, contacts in self.outputs},
        }


@dataclass
class Sampler:
    """Reads one sample at a time through ``execute`` (the client's, or a test's)."""

    execute: Callable[[Any], Any]
    channels: Sequence[int]
    ports: Sequence[int]
    kind: PositionKind = PositionKind.XY
    info: ControllerInfo | None = None
    last: Sample | None = None
    last_good: float | None = None
    failing_since: float | None = None
    refusals: dict[str, str] = field(default_factory=dict)

    def sample(self) -> Sample:
        now = time.time()
        try:
            sample = self._read(now)
        except (LineError, ProtocolError) as error:
            if self.failing_since is None:
                self.failing_since = now
            sample = Sample(now, error=str(error))
        else:
            self.failing_since = None
            self.last_good = now
        self.last = sample if sample.error is None else self.last
        return sample

    def _read(self, now: float) -> Sample:
        if self.info is None:
            self.info = self.execute(ReadInfo())
        info = self.info
        statuses = self.execute(ReadStatus())
        channels = []
        for ch in self.channels:
            if ch > info.max_channels:
                continue
            channels.append(
                ChannelSample(
                    ch,
                    info.channel(ch).model,
                    statuses[ch - 1],
                    self._maybe(f"position {ch}", ReadPosition(ch, self.kind)),
                    self._maybe(f"speed {ch}", ReadSpeed(ch)),
                    _name(self._maybe(f"job {ch}", ReadJobName(ch))),
                    self._maybe(f"step {ch}", ReadJobStep(ch)),
                )
            )
        alarms = self.execute(ReadAlarms())
        inputs = []
        outputs = []
        for port in self.ports:
            state = self._maybe(f"inputs {port}", ReadInputs(port))
            if state is not None:
                inputs.append((port, state.contacts))
            state = self._maybe(f"outputs {port}", ReadOutputs(port))
            if state is not None:
                outputs.append((port, state.contacts))
        return Sample(now, tuple(channels), alarms, tuple(inputs), tuple(outputs))

    def _maybe(self, what: str, command: Any) -> Any:
        """A reading the controller may refuse (no job, no such port): None, and noted."""
        try:
            value = self.execute(command)
        except ControllerError as error:
            self.refusals[what] = error.reason or error.describe
            return None
        self.refusals.pop(what, None)
        return value


def _name(value: object) -> str | None:
    return None if value is None else str(value)


def _clock(seconds: float) -> str:
    return datetime.fromtimestamp(seconds).strftime("%H:%M:%S")


def render_sample(
    sampler: Sampler, sample: Sample, rate: float, target: str = "", simulator: bool = False
) -> RenderableType:
    """The monitor's screen for one refresh; ``target`` (the session's banner) goes in the
    title, since the full screen hides the one printed on stderr."""
    failing = sample.error is not None
    shown = sampler.last if failing else sample
    parts: list[RenderableType] = []
    if failing:
        since = sampler.failing_since or sample.time
        last = _clock(sampler.last_good) if sampler.last_good else "never"
        parts.append(
            Text(
                f" NO ANSWER - the line stopped answering {sample.time - since:.0f} s ago "
                f"(last good answer: {last}) ",
                style="bold white on red",
            )
        )
        parts.append(Text(sample.error or "", style="red"))
    else:
        parts.append(Text(f"line OK  {_clock(sample.time)}  refresh {rate:g}/s", style="green"))
    if shown is not None:
        parts.append(_channels_table(shown, dim=failing))
        parts.append(_alarms_text(shown))
        rows = [(f"in {p}", c) for p, c in shown.inputs] + [
            (f"out {p}", c) for p, c in shown.outputs
        ]
        if rows:
            parts.append(lamps_table(rows, title="I/O"))
    if sampler.refusals:
        notes = "; ".join(f"{k}: {v}" for k, v in sorted(sampler.refusals.items()))
        parts.append(Text(f"not available: {notes}", style="dim"))
    parts.append(Text(LEGEND, style="dim"))
    parts.append(Text("q leaves", style="dim"))
    title = Text("robostar monitor")
    if target:
        title.append("  ").append(target, style="bold magenta" if simulator else "bold")
    return Panel(Group(*parts), title=title, border_style="red" if failing else "cyan")


_LETTERS = "SOARPM"
LEGEND = "state: S servo on  O origin  A alarm  R ready  P in position  M moving"
"""The state column's letters, one per AA bit, so that a channel's row fits 80 columns."""


def _state(status: Any) -> Text:
    text = Text()
    for letter, name in zip(_LETTERS, STATUS_BITS, strict=True):
        on = bool(getattr(status, name)) if status is not None else False
        style = ("bold red" if name == "alarm" else "bold green") if on else "dim"
        text.append(letter if on else "·", style=style)
    return text


def _position(values: tuple[float, ...]) -> str:
    # One decimal: six axes fit the 80-column row (the pendant's three are in `position`).
    return " ".join(f"{v:.1f}" for v in values)


def _channels_table(sample: Sample, *, dim: bool) -> Table:
    table = Table(box=None, pad_edge=False, style="dim" if dim else "")
    table.add_column("ch")
    table.add_column("model", max_width=10, no_wrap=True, overflow="ellipsis")
    table.add_column(_LETTERS, no_wrap=True)
    table.add_column("position", no_wrap=True, overflow="ellipsis")
    table.add_column("speed", justify="right")
    table.add_column("job", no_wrap=True)
    table.add_column("step", justify="right")
    for ch in sample.channels:
        pos = _position(ch.position.axes) if ch.position else "-"
        table.add_row(
            str(ch.channel),
            ch.model,
            _state(ch.status),
            pos,
            "-" if ch.speed is None else str(ch.speed),
            ch.job or "-",
            "-" if ch.step is None else str(ch.step),
        )
    return table


def _alarms_text(sample: Sample) -> Text:
    if not sample.alarms:
        return Text("alarms: none", style="green")
    return Text("alarms: " + "; ".join(str(a) for a in sample.alarms), style="bold red")


def _parse_list(text: str, lo: int, hi: int, what: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise UsageError(f"{what}: {text!r} is not a comma-separated list of numbers") from None
    for value in values:
        if not lo <= value <= hi:
            raise UsageError(f"{what}: {value} is not in {lo}-{hi}")
    return values


@click.command()
@click.option(
    "--rate",
    type=Finite(0.1, 20.0),
    default=2.0,
    show_default=True,
    help="Refreshes per second.",
)
@click.option(
    "--count",
    type=click.IntRange(min=1),
    default=None,
    help="Stop after this many refreshes (default: until q or Ctrl-C).",
)
@click.option(
    "--channels",
    default="1,2,3",
    show_default=True,
    help="The channels to show (those the controller has).",
)
@click.option("--ports", default="0", show_default=True, help="The I/O ports to show (0-4).")
@click.option(
    "--kind",
    type=click.Choice(["pulse", "angle", "xy"]),
    default="xy",
    show_default=True,
    help="How positions are shown.",
)
@common_options()
@pass_session
def monitor(
    session: ConsoleSession, rate: float, count: int | None, channels: str, ports: str, kind: str
) -> None:
    """Watch every channel live: status lamps, positions, speed, job and step, alarms, I/O.

    On a terminal it fills the screen and q leaves; otherwise (and with --json, one JSON object
    per line) it prints each refresh. When the line stops answering it says so in red.

    \b
    Example:
      robostar monitor --rate 5
      robostar --json monitor --count 10 --ports 0,1
    """
    chosen = _parse_list(channels, 1, 3, "--channels")
    port_list = _parse_list(ports, 0, 4, "--ports")
    if session.dry_run:
        session.plan(
            [ReadInfo(), ReadStatus(), *(ReadPosition(c) for c in chosen)],
            note="Repeated at every refresh, with CA, EF, ED, AB, GA and GB.",
        )
    _client_options(session)
    kinds = {"pulse": PositionKind.PULSE, "angle": PositionKind.ANGLE, "xy": PositionKind.XY}
    sampler = Sampler(session.client.execute, chosen, port_list, kinds[kind])
    # After the client is open: a served simulator is known only once it has answered AD.
    show = partial(render_sample, target=session.banner(), simulator=session.simulator)
    period = 1.0 / rate
    reader = KeyReader()
    if session.out.json or not reader.is_terminal() or not session.out.console.is_terminal:
        _print_samples(session, sampler, period, count, rate, show)
        return
    with (
        reader.cbreak(),
        Live(console=session.out.console, screen=True, auto_refresh=False) as live,
    ):
        done = 0
        while count is None or done < count:
            started = time.monotonic()
            sample = sampler.sample()
            done += 1
            live.update(show(sampler, sample, rate), refresh=True)
            try:
                while (left := period - (time.monotonic() - started)) > 0:
                    if any(k in ("q", "Q", "esc", "ctrl-c") for k in reader.read(left)):
                        return
            except TerminalLost:
                return


def _client_options(session: ConsoleSession) -> None:
    """A short reply timeout (unless --timeout is given) and reconnecting, for a client the
    monitor opens. In `robostar shell` the client is the shell's, open before this line ran,
    and ConsoleSession refuses options then (RuntimeError, its only one): `watch` keeps the shell's
    timeout and connection rather than ending the shell."""
    options: dict[str, Any] = {"reconnect": True}
    if session.settings.timeout is None:
        options["timeout"] = MONITOR_TIMEOUT
    with contextlib.suppress(RuntimeError):
        session.client_options(**options)


def _print_samples(
    session: ConsoleSession,
    sampler: Sampler,
    period: float,
    count: int | None,
    rate: float,
    show: Callable[[Sampler, Sample, float], RenderableType],
) -> None:
    done = 0
    while count is None or done < count:
        started = time.monotonic()
        sample = sampler.sample()
        done += 1
        session.out.result(sample.as_json(), partial(show, sampler, sample, rate))
        if count is not None and done >= count:
            break
        time.sleep(max(0.0, period - (time.monotonic() - started)))
