"""Output for a person (rich) or for a script (JSON), chosen once per run."""

from __future__ import annotations

import dataclasses
import enum
import json
import math
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import click
from rich.console import Console, RenderableType
from rich.table import Table
from rich.text import Text

from robostar.cli.failures import Failure
from robostar.protocol.fields import FileName
from robostar.types import ChannelStatus

__all__ = [
    "STATUS_BITS",
    "Output",
    "format_number",
    "jsonable",
    "lamp",
    "lamps_table",
    "status_lamps",
]

STATUS_BITS = ("servo_on", "origin", "alarm", "ready", "in_position", "running")
"""AA's bits in the pendant's order."""


def jsonable(value: Any) -> Any:
    """``value`` as plain JSON data: dataclasses as objects, enums by lower-case name, file
    names as text."""
    if isinstance(value, enum.Enum):
        return value.name.lower()
    if isinstance(value, FileName):
        return str(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, bytes | bytearray):
        return value.hex(" ")
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, str | int | float | bool) or value is None:
        return value
    if isinstance(value, Iterable):
        return [jsonable(v) for v in value]
    return str(value)


def format_number(value: float) -> str:
    """A coordinate as the pendant shows it: three decimals."""
    return f"{value:.3f}"


def lamp(on: bool, label: str = "", *, alarm: bool = False) -> Text:
    """A lamp: a filled dot when on (red for an alarm), an empty one when off."""
    style = ("bold red" if alarm else "bold green") if on else "dim"
    mark = "●" if on else "○"
    return Text(f"{mark} {label}".rstrip(), style=style)


def status_lamps(status: ChannelStatus) -> Text:
    """The six AA bits of a channel as lamps on one line."""
    text = Text()
    for i, name in enumerate(STATUS_BITS):
        if i:
            text.append("  ")
        text.append_text(lamp(getattr(status, name), name.replace("_", " "), alarm=name == "alarm"))
    return text


def lamps_table(rows: Iterable[tuple[str, tuple[bool, ...]]], *, title: str = "") -> Table:
    """A row of 16 contact lamps per port, contact numbers as the header."""
    table = Table(title=title or None, box=None, pad_edge=False)
    table.add_column("port")
    for contact in range(16):
        table.add_column(f"{contact:X}", justify="center")
    for label, contacts in rows:
        table.add_row(
            label, *(Text("●", "bold green") if c else Text("○", "dim") for c in contacts)
        )
    return table


class Output:
    """Where a command's results go.

    In JSON mode each result is one JSON document on stdout, and notes go to stderr so that the
    output stays parseable. For a person, results are rich text on stdout; notes (such as the
    warning before a motion) go to stderr as well, so a pipe never mixes them in.
    """

    def __init__(self, json_mode: bool):
        self.json = json_mode
        # Keys every JSON result and error carries: ``"simulator": true|false`` and ``"url"``
        # once the target is known, the profile's name.
        self.extra: dict[str, Any] = {}
        # Consoles resolve sys.stdout/sys.stderr when they print, so a test runner that swaps
        # the streams sees the output.
        self.console = Console(highlight=False)
        self.err = Console(stderr=True, highlight=False, soft_wrap=True)

    def result(
        self,
        data: Mapping[str, Any],
        human: RenderableType | Callable[[], RenderableType] | None = None,
    ) -> None:
        """Print a result: ``data`` as JSON, or ``human`` (built only when needed)."""
        if self.json:
            click.echo(json.dumps(jsonable({**data, **self.extra}), ensure_ascii=False))
            return
        shown = human() if callable(human) else human
        if shown is not None:
            self.console.print(shown)

    def note(self, text: str, *, style: str = "") -> None:
        """A line for the person at the console (stderr), never mixed into results."""
        self.err.print(Text(text, style=style))

    def warn(self, text: str) -> None:
        """A warning the technician must see: motion about to start, files overwritten."""
        self.err.print(Text(text, style="bold yellow"))

    def failure(self, failure: Failure) -> None:
        """An error: a JSON object on stderr (with the keys every result carries, such as
        ``"simulator"``), or the sentence and its hint."""
        if self.json:
            data = {**failure.as_json(), **jsonable(self.extra)}
            click.echo(json.dumps(data, ensure_ascii=False), err=True)
            return
        self.err.print(Text("Error: ", style="bold red") + Text(failure.message))
        if failure.hint:
            self.err.print(Text(failure.hint, style="dim"))
        if failure.detail:
            self.err.print(Text(failure.detail, style="dim"))
