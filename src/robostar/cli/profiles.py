"""Named controllers (profiles) read from a TOML file in the user's config folder.

The file is ``robots.toml`` in the user's config folder (``platformdirs``), or the file named by
``ROBOSTAR_CONFIG``. Each ``[robots.NAME]`` table names one controller::

    [robots.cell1]
    port = "/dev/ttyUSB0"      # required: any --port URL
    baud = 9600                # serial speed
    timeout = 2.0              # reply timeout, seconds
    robot_type = "SCARA"       # what the controller should report (checked by restore)
    channels = { 1 = "left arm", 2 = "right arm" }

Every validation error names the key (``robots.cell1.timeout``).
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import click

__all__ = ["CONFIG_ENV", "Profile", "ProfileError", "config_path", "load_profiles", "profile"]

CONFIG_ENV = "ROBOSTAR_CONFIG"

_KEYS = {"port", "baud", "timeout", "robot_type", "channels"}


class ProfileError(click.UsageError):
    """The profile file is unreadable, or a key in it is wrong (the key is named)."""


@dataclass(frozen=True, slots=True)
class Profile:
    """One named controller."""

    name: str
    port: str
    baud: int | None = None
    timeout: float | None = None
    robot_type: str | None = None
    channels: dict[int, str] = field(default_factory=dict)

    def channel_name(self, channel: int) -> str:
        """``"2 (right arm)"``, or just ``"2"`` when the profile names no such channel."""
        name = self.channels.get(channel)
        return f"{channel} ({name})" if name else str(channel)


def config_path() -> Path:
    """Where the profiles live: ``$ROBOSTAR_CONFIG``, else ``robots.toml`` in the config dir."""
    override = os.environ.get(CONFIG_ENV)
    if override:
        return Path(override)
    # Imported here: only a run that needs profiles pays for platformdirs.
    import platformdirs

    return Path(platformdirs.user_config_dir("robostar")) / "robots.toml"


def load_profiles(path: Path | None = None) -> dict[str, Profile]:
    """Every profile in the file (none when the file does not exist)."""
    path = path or config_path()
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return {}
    except (OSError, UnicodeDecodeError) as error:
        raise ProfileError(f"cannot read the profile file {path}: {error}") from error
    except tomllib.TOMLDecodeError as error:
        raise ProfileError(f"the profile file {path} is not valid TOML: {error}") from error
    unknown = set(data) - {"robots"}
    if unknown:
        raise ProfileError(f"{path}: unknown key {sorted(unknown)[0]!r} (only [robots.NAME])")
    robots = data.get("robots", {})
    if not isinstance(robots, dict):
        raise ProfileError(f"{path}: 'robots' must be a table of [robots.NAME] tables")
    return {name: _profile(path, name, table) for name, table in robots.items()}


def profile(name: str, path: Path | None = None) -> Profile:
    """The profile called ``name``; the error lists the names there are."""
    path = path or config_path()
    profiles = load_profiles(path)
    if name not in profiles:
        known = ", ".join(sorted(profiles)) or "none"
        raise ProfileError(f"--robot: no profile {name!r} in {path} (profiles: {known})")
    return profiles[name]


def _profile(path: Path, name: str, table: object) -> Profile:
    where = f"{path}: robots.{name}"
    if not isinstance(table, dict):
        raise ProfileError(f"{where} must be a table")
    unknown = set(table) - _KEYS
    if unknown:
        key = sorted(unknown)[0]
        raise ProfileError(f"{where}.{key}: unknown key (allowed: {', '.join(sorted(_KEYS))})")
    port = table.get("port")
    if not isinstance(port, str) or not port.strip():
        raise ProfileError(f"{where}.port: required, a port URL such as /dev/ttyUSB0 or sim://")
    baud = table.get("baud")
    if baud is not None and (isinstance(baud, bool) or not isinstance(baud, int) or baud <= 0):
        raise ProfileError(f"{where}.baud: must be a whole number above 0, not {baud!r}")
    timeout = table.get("timeout")
    if timeout is not None:
        if isinstance(timeout, bool) or not isinstance(timeout, int | float):
            raise ProfileError(f"{where}.timeout: must be a number of seconds, not {timeout!r}")
        if not (math.isfinite(timeout) and 0.01 <= timeout <= 3600):
            raise ProfileError(f"{where}.timeout: must be 0.01-3600 seconds, not {timeout!r}")
        timeout = float(timeout)
    robot_type = table.get("robot_type")
    if robot_type is not None and not isinstance(robot_type, str):
        raise ProfileError(f"{where}.robot_type: must be text, not {robot_type!r}")
    return Profile(name, port.strip(), baud, timeout, robot_type, _channels(where, table))


def _channels(where: str, table: dict[str, object]) -> dict[int, str]:
    raw = table.get("channels", {})
    if not isinstance(raw, dict):
        raise ProfileError(f'{where}.channels: must be a table such as {{ 1 = "left arm" }}')
    channels: dict[int, str] = {}
    for key, value in raw.items():
        if key not in ("1", "2", "3"):
            raise ProfileError(f"{where}.channels.{key}: channels are 1, 2 or 3")
        if not isinstance(value, str):
            raise ProfileError(f"{where}.channels.{key}: must be a name, not {value!r}")
        channels[int(key)] = value
    return channels
