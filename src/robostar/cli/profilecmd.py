"""``robostar profiles``: the named controllers of the profile file, and where that file is."""

from __future__ import annotations

from typing import Any

import click
from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from robostar.cli.options import common_options
from robostar.cli.profiles import Profile, config_path, load_profiles
from robostar.cli.session import ConsoleSession, is_simulator, pass_session

__all__ = ["profiles"]


@click.command()
@common_options()
@pass_session
def profiles(session: ConsoleSession) -> None:
    """List the named controllers (profiles) usable with --robot NAME.

    The file is robots.toml in your config folder (or the file named by ROBOSTAR_CONFIG); each
    [robots.NAME] table has port (required), baud, timeout, robot_type and channels.

    \b
    Example:
      robostar profiles
      robostar --robot cell1 status
    """
    path = config_path()
    found = load_profiles(path)
    active = session.settings.robot
    rows = [_row(p, p.name == active) for p in found.values()]
    session.out.result(
        {"file": str(path), "exists": path.exists(), "active": active, "profiles": rows},
        lambda: _view(str(path), path.exists(), list(found.values()), active),
    )


def _row(p: Profile, active: bool) -> dict[str, Any]:
    return {
        "name": p.name,
        "port": p.port,
        "simulator": is_simulator(p.port),
        "baud": p.baud,
        "timeout": p.timeout,
        "robot_type": p.robot_type,
        "channels": {str(k): v for k, v in sorted(p.channels.items())},
        "active": active,
    }


def _view(path: str, exists: bool, found: list[Profile], active: str | None) -> RenderableType:
    if not found:
        where = "has no [robots.NAME] table" if exists else "does not exist"
        return Text(f"No profiles: {path} {where}. See `robostar profiles --help` for the format.")
    table = Table(title=f"Profiles in {path}", title_justify="left")
    for column in ("", "name", "port", "baud", "timeout", "robot type", "channels"):
        table.add_column(column)
    for p in found:
        port = f"{p.port} (SIMULATOR)" if is_simulator(p.port) else p.port
        channels = ", ".join(f"{k}={v}" for k, v in sorted(p.channels.items()))
        table.add_row(
            "*" if p.name == active else "",
            p.name,
            port,
            str(p.baud or ""),
            f"{p.timeout:g} s" if p.timeout else "",
            p.robot_type or "",
            channels,
        )
    return Group(table, Text("* the active profile (--robot)", style="dim"))
