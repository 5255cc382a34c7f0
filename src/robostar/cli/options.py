"""Options every subcommand shares, and small parameter types."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

import click

from robostar.cli.session import ConsoleSession

__all__ = ["MAX_SECONDS", "ON_OFF", "ControllerFile", "Finite", "common_options", "get_session"]

F = TypeVar("F", bound=Callable[..., Any])

ON_OFF = click.Choice(["on", "off"], case_sensitive=False)

MAX_SECONDS = 1_000_000.0
"""The longest wait any option takes (11 days): beyond it the clock's waits overflow."""


class Finite(click.FloatRange):
    """A float range that refuses NaN and the infinities (click's FloatRange lets NaN through,
    as every comparison with NaN is false), and caps an open upper end at ``MAX_SECONDS``."""

    name = "finite number"

    def __init__(self, min: float | None = None, max: float | None = None) -> None:
        super().__init__(min, MAX_SECONDS if max is None else max)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return super().convert(number, param, ctx)


if TYPE_CHECKING:
    _TextParam = click.ParamType[str]
else:  # click before 8.2 has no generic ParamType at run time
    _TextParam = click.ParamType


class ControllerFile(_TextParam):
    """A controller file name, refused before the wire when the controller cannot hold it
    (spaces and NUL bytes are refused, never dropped); ``kind`` "JOB"/"PNT" restricts it."""

    name = "file name"

    def __init__(self, kind: str | None = None) -> None:
        self.kind = kind

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        # Imported here: offline commands (decode) load no client code.
        from robostar.client.files import parse_name
        from robostar.errors import FieldError, UsageError

        what = param.human_readable_name if param is not None else "file name"
        try:
            return str(parse_name(str(value), what).check("", what, kind=self.kind))
        except FieldError as error:
            self.fail(error.message, param, ctx)
        except UsageError as error:
            self.fail(str(error), param, ctx)


def get_session(ctx: click.Context) -> ConsoleSession:
    """The run's session (``ctx.obj`` of the root group)."""
    session = ctx.find_object(ConsoleSession)
    if session is None:
        raise click.UsageError("this command runs only under the robostar group")
    return session


def _set_json(ctx: click.Context, _param: click.Parameter, value: bool) -> None:
    if value:
        get_session(ctx).set_json(True)


def _set_channel(ctx: click.Context, _param: click.Parameter, value: int | None) -> None:
    if value is not None:
        get_session(ctx).set_channel(value)


def common_options(*, channel: bool = False) -> Callable[[F], F]:
    """``--json`` (and ``--channel``) accepted after a command's name as well as before it."""

    def decorate(func: F) -> F:
        func = click.option(
            "--json",
            "json_after",
            is_flag=True,
            expose_value=False,
            is_eager=True,
            callback=_set_json,
            help="Machine-readable output (same as the global --json).",
        )(func)
        if channel:
            func = click.option(
                "--channel",
                "-c",
                "channel_after",
                type=click.IntRange(1, 3),
                expose_value=False,
                is_eager=True,
                callback=_set_channel,
                help="Channel 1-3 (same as the global --channel).",
            )(func)
        return func

    return decorate
