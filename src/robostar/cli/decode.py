"""``robostar decode``: annotate a hex dump, raw capture or trace file frame by frame."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import click
from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from robostar.cli.annotate import Annotated, Chunk, Direction, annotate, short
from robostar.cli.captures import CaptureFormat, parse_capture, parse_hexdump
from robostar.cli.options import common_options
from robostar.cli.session import ConsoleSession, pass_session
from robostar.errors import UsageError

__all__ = ["decode"]

_ARROWS = {Direction.TO_CONTROLLER: "H→C", Direction.TO_HOST: "C→H", None: "?"}


def _fields_text(frame: Annotated) -> Text:
    parts = []
    for key, value in frame.fields.items():
        if key == "body" and "result" in frame.fields:
            continue
        parts.append(f"{key}={short(value)}")
    text = Text(" ".join(parts))
    if frame.note:
        if parts:
            text.append("  ")
        text.append(frame.note, style="italic dim")
    return text


def _lrc_text(frame: Annotated) -> Text:
    if frame.lrc is None:
        return Text("")
    return Text(frame.lrc, style="green" if frame.lrc == "ok" else "bold red")


def _table(frames: Sequence[Annotated], show_bytes: bool) -> RenderableType:
    table = Table(box=None, pad_edge=False, show_edge=False)
    times = [f.time for f in frames if f.time is not None]
    start = min(times) if times else 0.0
    timed = bool(times)
    table.add_column("#", justify="right")
    if timed:
        table.add_column("t (s)", justify="right")
    for name in ("dir", "kind", "cmd", "flag", "LRC", "fields"):
        table.add_column(name)
    if show_bytes:
        table.add_column("bytes", overflow="fold")
    for f in frames:
        arrow = _ARROWS[f.direction] + ("*" if f.inferred else "")
        cmd = f.command or ""
        if f.name:
            cmd = f"{cmd} {f.name}"
        row: list[str | Text] = [str(f.index)]
        if timed:
            row.append("" if f.time is None else f"{f.time - start:.3f}")
        row += [arrow, f.kind, cmd, f.flag or "", _lrc_text(f), _fields_text(f)]
        if show_bytes:
            row.append(f.raw.hex(" "))
        table.add_row(*row)
    counts = Counter(f.kind for f in frames)
    bad = sum(1 for f in frames if f.lrc not in (None, "ok"))
    summary = ", ".join(f"{n} {kind}" for kind, n in counts.items()) or "no frames"
    footer = Text(f"{len(frames)} frame(s): {summary}; {bad} with a bad LRC.", style="dim")
    legend = Text("* direction inferred from the bytes (the capture did not say).", style="dim")
    parts: list[RenderableType] = [table, footer]
    if any(f.inferred for f in frames):
        parts.append(legend)
    return Group(*parts)


@click.command()
@click.argument("source", required=False, default=None)
@click.option(
    "--format",
    "fmt",
    type=click.Choice([f.value for f in CaptureFormat]),
    default="auto",
    show_default=True,
    help="What SOURCE holds; auto tells a trace (JSON lines), raw bytes and a hex dump apart.",
)
@click.option("--hex", "hex_text", default=None, help="Decode these hex bytes instead of a file.")
@click.option("--bytes", "show_bytes", is_flag=True, help="Show each frame's bytes as well.")
@common_options()
@pass_session
def decode(
    session: ConsoleSession, source: str | None, fmt: str, hex_text: str | None, show_bytes: bool
) -> None:
    """Annotate each frame of a capture: direction, command, fields, flag, LRC verdict.

    SOURCE is a file (or - for standard input): a hex dump (lines may start with > or < for
    host-to-controller and controller-to-host; xxd and hexdump -C output work too), a raw byte
    capture, or a trace written with --trace. Answers are decoded with the request they answer.

    \b
    Examples:
      robostar decode --hex "02 FF 41 41 03 BC"
      robostar --trace line.jsonl status && robostar decode line.jsonl
      robostar decode capture.bin --format raw
    """
    chunks: list[Chunk]
    if hex_text is not None:
        if source is not None:
            raise UsageError("give a SOURCE file or --hex, not both")
        chunks = parse_hexdump(hex_text)
    elif source is None:
        raise UsageError("give a SOURCE file (or - for standard input), or --hex BYTES")
    else:
        try:
            with click.open_file(source, "rb") as stream:
                data = stream.read()
        except OSError as error:
            raise UsageError(f"cannot read {source}: {error.strerror or error}") from None
        chunks = parse_capture(data, CaptureFormat(fmt))
    frames = annotate(chunks)
    session.out.result(
        {"frames": [f.as_json() for f in frames]},
        lambda: _table(frames, show_bytes),
    )
