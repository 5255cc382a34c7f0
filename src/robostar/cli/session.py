"""One run of the command: the global options, the client (opened on first use) and dry runs."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, TypeVar

import click
from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from robostar.cli.annotate import describe_request
from robostar.cli.render import Output
from robostar.commands import Command
from robostar.protocol.frame import encode_packet

if TYPE_CHECKING:
    from robostar.client import Client

__all__ = ["DryRunDone", "PlannedFrame", "Session", "Settings", "pass_session"]

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class Settings:
    """The global options."""

    port: str
    timeout: float | None
    json: bool
    trace: str | None
    channel: int
    dry_run: bool


@dataclass(frozen=True, slots=True)
class PlannedFrame:
    """A frame a dry run would send, with what it means."""

    frame: bytes
    meaning: str


class DryRunDone(Exception):
    """Raised after a dry run has printed its frames, to end the command without sending."""


class Session:
    """Shared by every command of one run; ``ctx.obj`` of the root group."""

    def __init__(self, settings: Settings):
        self.settings = settings
        self.out = Output(settings.json)
        self._client: Client | None = None
        self._client_options: dict[str, Any] = {}

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
            self.out = Output(True)

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

            options: dict[str, Any] = dict(self._client_options)
            if self.settings.timeout is not None:
                options["timeout"] = self.settings.timeout
            if self.settings.trace:
                options["trace"] = self.settings.trace
            self._client = Client(self.settings.port, **options)
        return self._client

    def close(self) -> None:
        if self._client is not None:
            client, self._client = self._client, None
            client.close()

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
            {"dry_run": True, "port": self.settings.port, "frames": rows, "note": note},
            lambda: _plan_table(planned, note, self.settings.port),
        )
        raise DryRunDone

    def announce(self, text: str) -> None:
        """Say what is about to move, before it does (not in a dry run, where nothing moves)."""
        if not self.dry_run:
            self.out.warn(text)


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


pass_session = click.make_pass_decorator(Session)
