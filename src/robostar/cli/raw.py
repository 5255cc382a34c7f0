"""``robostar raw``: send any command as given and show the decoded answer."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Self

import click
from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from robostar.cli.annotate import FLAG_NAMES, describe_request, printable, short
from robostar.cli.options import common_options
from robostar.cli.render import jsonable
from robostar.cli.session import ConsoleSession, pass_session
from robostar.commands import COMMANDS, Command, decode_request, split_answer
from robostar.commands.base import Shape
from robostar.errors import RobostarError, UsageError
from robostar.protocol.fields import Reader
from robostar.protocol.frame import encode_packet

__all__ = ["RawAnswer", "RawCommand", "build_raw", "parse_params", "raw"]

_SHAPES: dict[str, Shape] = {
    "single": Shape.SINGLE,
    "multi": Shape.MULTI,
    "two-phase": Shape.TWO_PHASE,
}


@dataclass(frozen=True, slots=True)
class RawAnswer:
    """The answer packets as they came, and the typed result when the command is known."""

    packets: tuple[bytes, ...]
    result: Any = None
    problem: str = ""


@dataclass(frozen=True)
class RawCommand(Command[RawAnswer]):
    """A request sent as given; ``typed`` decodes the answer when the command is known.

    Subclassed per code by :func:`build_raw`, since the code and shape are class attributes.
    """

    params: bytes
    typed: Command[Any] | None = None

    def encode_params(self) -> bytes:
        return self.params

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        return cls(reader.rest())

    def decode_answer(self, packets: Sequence[bytes]) -> RawAnswer:
        if self.typed is None:
            return RawAnswer(tuple(packets))
        try:
            return RawAnswer(tuple(packets), self.typed.decode_answer(packets))
        except RobostarError as error:
            return RawAnswer(tuple(packets), problem=str(error))

    def encode_answer(self, result: RawAnswer) -> list[bytes]:
        return list(result.packets)


def parse_params(params: Sequence[str]) -> bytes:
    """Join the parameters: ASCII text as it is, or hex after ``0x`` (``0x3031`` is ``01``)."""
    out = bytearray()
    for param in params:
        if param.lower().startswith("0x"):
            digits = param[2:].replace("_", "")
            if not re.fullmatch(r"(?:[0-9A-Fa-f]{2})+", digits):
                raise UsageError(f"parameter {param!r}: hex after 0x needs pairs of hex digits")
            out += bytes.fromhex(digits)
        else:
            try:
                out += param.encode("ascii")
            except UnicodeEncodeError:
                raise UsageError(f"parameter {param!r} is not ASCII; give bytes as 0x..") from None
    return bytes(out)


def build_raw(code: str, params: bytes, shape: str | None) -> tuple[RawCommand, str]:
    """The command to send, and a warning when the bytes do not decode as ``code``."""
    code = code.upper()
    if not re.fullmatch(r"[A-Z]{2}", code):
        raise UsageError(f"command {code!r}: give the two letters of a command, such as AA")
    data = b"\xff" + code.encode("ascii") + params
    typed: Command[Any] | None = None
    warning = ""
    kind_shape: Shape
    classes = COMMANDS.get(code)
    if classes:
        try:
            typed = decode_request(data)
        except RobostarError as error:
            warning = f"the parameters do not decode as {code} ({error}); sending them as given"
        known = type(typed) if typed else classes[0]
        if known.SHAPE is Shape.UPLOAD:
            raise UsageError("FB uploads a file in several packets: use `robostar files put`")
        kind_shape, changes = known.SHAPE, known.CHANGES_STATE
        if shape is not None and _SHAPES[shape] is not kind_shape:
            raise UsageError(f"{code} runs as {kind_shape.value}, not {shape}")
    else:
        warning = f"{code} is not in the manual's command list; its answer is shown undecoded"
        kind_shape = _SHAPES[shape or "single"]
        # An unknown command may change anything: never resend it after a lost answer.
        changes = True
    cls = type(
        f"Raw{code}",
        (RawCommand,),
        {"CODE": code, "SHAPE": kind_shape, "CHANGES_STATE": changes},
    )
    command: RawCommand = cls(params, typed)
    return command, warning


def _answer_view(command: RawCommand, answer: RawAnswer) -> RenderableType:
    table = Table(box=None, pad_edge=False, title="answer", title_justify="left")
    table.add_column("#", justify="right")
    table.add_column("flag")
    table.add_column("body")
    for i, packet in enumerate(answer.packets, 1):
        split = split_answer(packet)
        table.add_row(
            str(i), FLAG_NAMES.get(split.flag, f"0x{split.flag:02X}"), Text(printable(split.body))
        )
    parts: list[RenderableType] = [
        Text(f"sent  {encode_packet(command.encode()).hex(' ')}"),
        Text(f"      {describe_request(command.encode())}", style="dim"),
        table,
    ]
    if answer.result is not None:
        parts.append(Text(f"decoded: {short(jsonable(answer.result))}", style="bold"))
    if answer.problem:
        parts.append(Text(f"the answer does not decode: {answer.problem}", style="red"))
    return Group(*parts)


@click.command()
@click.argument("code")
@click.argument("params", nargs=-1)
@click.option(
    "--shape",
    type=click.Choice(list(_SHAPES)),
    default=None,
    help="How the answer comes, for a command the manual does not list (default single).",
)
@common_options()
@pass_session
def raw(session: ConsoleSession, code: str, params: tuple[str, ...], shape: str | None) -> None:
    """Send command CODE with PARAMS as given and show the answer, decoded when known.

    Each parameter is ASCII text, or hex bytes after 0x; they are joined with nothing between.
    Channels are the wire's digits here: channel 1 is 0. For the engineer who needs a command
    the tool does not wrap yet; --dry-run shows the frame without sending it.

    \b
    Examples:
      robostar raw AA                 # status of every channel
      robostar raw AC 0 2             # position of channel 1, XY
      robostar raw GA 01              # inputs of port 1
      robostar --dry-run raw BG 0x30  # the jog-stop frame for channel 1
    """
    command, warning = build_raw(code, parse_params(params), shape)
    if warning:
        session.out.note(f"Note: {warning}.")
    if session.dry_run:
        session.plan([command])
    if command.CHANGES_STATE and command.CODE.startswith("B"):
        session.announce(f"Sending {command.CODE}: the robot may move.")
    answer = session.send(command)
    packets = [
        {
            "flag": FLAG_NAMES.get(split_answer(p).flag, f"0x{split_answer(p).flag:02X}"),
            "body": printable(split_answer(p).body),
            "hex": p.hex(" "),
        }
        for p in answer.packets
    ]
    session.out.result(
        {
            "request": {
                "hex": encode_packet(command.encode()).hex(" "),
                "meaning": describe_request(command.encode()),
            },
            "answer": packets,
            "result": answer.result,
            "problem": answer.problem or None,
        },
        lambda: _answer_view(command, answer),
    )
