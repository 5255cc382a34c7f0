"""Options every subcommand shares, and small parameter types."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import click

from robostar.cli.session import Session

__all__ = ["ON_OFF", "common_options", "get_session"]

F = TypeVar("F", bound=Callable[..., Any])

ON_OFF = click.Choice(["on", "off"], case_sensitive=False)


def get_session(ctx: click.Context) -> Session:
    """The run's session (``ctx.obj`` of the root group)."""
    session = ctx.find_object(Session)
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
