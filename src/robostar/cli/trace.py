"""``robostar trace check``: every frame of a recorded trace that robostar's reading refuses.

The file a user attaches to a report of a problem with a real controller: record with
``--trace FILE``, then ``robostar trace check FILE`` names each frame robostar would refuse —
the rule it breaks and its bytes — and exits 1 if there is any (docs/field-problems.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import click
from rich.table import Table
from rich.text import Text

from robostar.cli.annotate import Annotated, Direction, annotate
from robostar.cli.captures import CaptureFormat, parse_capture
from robostar.cli.options import common_options
from robostar.cli.session import ConsoleSession, pass_session
from robostar.errors import UsageError
from robostar.protocol.frame import FrameDecoder, Packet
from robostar.protocol.link import announced_wait

__all__ = ["Problem", "problems", "trace"]

_TWO_PHASE_WAITS = ("DB", "DC")


@dataclass(frozen=True, slots=True)
class Problem:
    """A frame robostar's reading refuses: which, the rule, the bytes."""

    index: int
    direction: str
    command: str
    rule: str
    raw: bytes

    def as_json(self) -> dict[str, object]:
        return {
            "frame": self.index,
            "direction": self.direction,
            "command": self.command,
            "rule": self.rule,
            "bytes": self.raw.hex(" "),
        }


def _rule(frame: Annotated, first_answers: set[int]) -> str | None:
    if frame.lrc not in (None, "ok"):
        return f"bad LRC ({frame.lrc}): the receiver answers NAK"
    if frame.kind in ("corrupt", "noise") or "does not decode" in frame.note:
        return frame.note or frame.kind
    if frame.index in first_answers:
        data = next((e.data for e in FrameDecoder().feed(frame.raw) if isinstance(e, Packet)), b"")
        if data and announced_wait(data) is None:
            return "a two-phase first answer's wait must be two digits (0-99 s)"
    return None


def problems(frames: list[Annotated]) -> list[Problem]:
    """The frames of an annotated trace that robostar's reading refuses."""
    first_answers: set[int] = set()
    waiting: str | None = None
    for frame in frames:  # DB/DC: the first answer after the request carries the wait
        if frame.direction is Direction.TO_CONTROLLER and frame.kind == "request":
            waiting = frame.command if frame.command in _TWO_PHASE_WAITS else None
        elif waiting and frame.direction is Direction.TO_HOST and frame.kind == "answer":
            first_answers.add(frame.index)
            waiting = None
    found = []
    for frame in frames:
        rule = _rule(frame, first_answers)
        if rule is not None:
            direction = (
                "host→controller"
                if frame.direction is Direction.TO_CONTROLLER
                else ("controller→host")
            )
            found.append(Problem(frame.index, direction, frame.command or "", rule, frame.raw))
    return found


@click.group()
def trace() -> None:
    """Work with wire traces (the JSON-lines files --trace writes).

    \b
    Example:
      robostar trace check field.trace
    """


@trace.command("check")
@click.argument("source", type=click.Path(dir_okay=False))
@common_options()
@pass_session
def check(session: ConsoleSession, source: str) -> None:
    """Flag every frame of a trace that robostar's reading would refuse (exit 1 if any).

    Each is named with the rule it breaks and its bytes: attach the output, and the trace, to
    a report of a problem with a real controller (docs/field-problems.md).

    \b
    Example:
      robostar --port /dev/ttyUSB0 --trace field.trace backup ./b
      robostar trace check field.trace
    """
    try:
        with open(source, "rb") as stream:
            data = stream.read()
    except OSError as error:
        raise UsageError(f"cannot read {source}: {error.strerror or error}") from None
    frames = annotate(parse_capture(data, CaptureFormat.TRACE))
    found = problems(frames)

    def human() -> Table | Text:
        if not found:
            return Text(f"{len(frames)} frame(s): robostar reads every one.", style="green")
        table = Table(title=f"{len(found)} of {len(frames)} frame(s) refused", box=None)
        for name in ("#", "dir", "cmd", "rule", "bytes"):
            table.add_column(name, overflow="fold")
        for p in found:
            table.add_row(str(p.index), p.direction, p.command, p.rule, p.raw.hex(" "))
        return table

    session.out.result(
        {"frames": len(frames), "problems": [p.as_json() for p in found]},
        human,
    )
    if found:
        raise click.exceptions.Exit(1)
