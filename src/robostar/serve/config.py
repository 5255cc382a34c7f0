"""The line server's configuration: TOML or command line -> one validated :class:`ServeConfig`."""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robostar.errors import UsageError
from robostar.transport.url import parse_url

__all__ = [
    "FACE_NAMES",
    "SHARED_SCOPES",
    "ConfigError",
    "LineConfig",
    "ServeConfig",
    "config_from_mapping",
    "default_audit_path",
    "load_config",
    "parse_line_arg",
]

FACE_NAMES = frozenset(("n1", "api", "mqtt", "opcua", "web", "metrics", "modbus"))
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,31}$")
SHARED_SCOPES = frozenset(("globals",))
"""What a line may share beside its lease holder (``[lines.X] shared = [...]``): ``"globals"``,
the global variable writes (GW) an MES makes beside the host program. Everything else (motion,
jogs, jobs, servo, speed, outputs, files, points, parameters, alarm resets) needs the lease."""


class ConfigError(UsageError):
    """The configuration is wrong; the message starts with the key at fault."""


@dataclass(frozen=True)
class LineConfig:
    """One controller line: its name, URL and how often the poller reads what.

    ``poll_interval`` is for status and positions; ``slow_interval`` for speed, job, step, alarms
    and I/O; ``history_interval`` for the alarm history (a multi-packet read). ``max_age`` is
    deprecated (parsed, warned about when not 0): reads are linearizable unless a request asks
    for a max_age of its own.
    """

    name: str
    url: str
    baudrate: int | None = None
    timeout: float = 2.0
    poll_interval: float = 0.2
    slow_interval: float = 1.0
    history_interval: float = 10.0
    poll_share: float = 1.0
    """The poller's share of the line's time (0 < share <= 1) while consumers read: after a
    poll exchange it waits until its exchanges took at most this share, so that hosts' reads
    meet fewer long poll reads on the wire (on a slow line, a host's read arriving during a
    poll read waits for its end). 1 (the default): no limit. The model then refreshes less
    often while consumers read; never so little that it goes stale."""
    rest_interval: float = 10.0
    """The longest a channel's positions (and the alarm history) go without a real read
    while status reads vouch for them: while a channel rests (servo on, in position, not
    running) each status read confirms them instead (see
    :mod:`robostar.serve.status_witness`); this bounds how long a motion hidden between two
    status reads can go unseen."""
    io_ports: tuple[int, ...] = (0,)
    max_age: float | None = None
    """Deprecated: no effect (reads are answered from the model only when a request asks)."""
    channels: dict[int, str] = field(default_factory=dict)
    robot: str | None = None
    shared: frozenset[str] = frozenset()
    """What any consumer may write without the lease, beside its holder (see
    :data:`SHARED_SCOPES`); empty (the default): every state change needs the lease."""

    def __post_init__(self) -> None:
        where = f"lines.{self.name}"
        if not _NAME.match(self.name):
            raise ConfigError(
                f"lines.{self.name!r}: a line name is a letter then letters, digits, _ or -"
            )
        if not self.url:
            raise ConfigError(f"{where}.url: missing")
        try:
            parse_url(self.url)  # a URL that cannot open is refused here, not found at start
        except UsageError as exc:
            raise ConfigError(f"{where}.url: {exc}") from None
        if self.baudrate is not None and self.baudrate <= 0:
            raise ConfigError(f"{where}.baudrate: {self.baudrate} is not a positive number")
        for key in (
            "timeout",
            "poll_interval",
            "slow_interval",
            "history_interval",
            "rest_interval",
        ):
            value = getattr(self, key)
            if not _seconds(value):
                raise ConfigError(f"{where}.{key}: {value!r} is not a positive number of seconds")
        if not (isinstance(self.poll_share, (int, float)) and 0 < self.poll_share <= 1):
            raise ConfigError(
                f"{where}.poll_share: {self.poll_share!r} is not a share of the line's time"
                " (more than 0, at most 1)"
            )
        if self.max_age is not None and not _seconds(self.max_age, zero=True):
            raise ConfigError(f"{where}.max_age: {self.max_age!r} is not 0 or more seconds")
        for port in self.io_ports:
            if not isinstance(port, int) or not 0 <= port <= 4:
                raise ConfigError(f"{where}.io_ports: {port!r} is not a port 0-4")
        for number in self.channels:
            if not isinstance(number, int) or not 1 <= number <= 3:
                raise ConfigError(f"{where}.channels: {number!r} is not a channel 1-3")
        for scope in self.shared:
            if scope not in SHARED_SCOPES:
                known = ", ".join(sorted(SHARED_SCOPES))
                raise ConfigError(f"{where}.shared: {scope!r} cannot be shared (only: {known})")


@dataclass(frozen=True)
class ServeConfig:
    """Every line and the raw sections of the faces (``faces["mqtt"]`` is the ``[mqtt]`` table)."""

    lines: tuple[LineConfig, ...]
    faces: dict[str, dict[str, Any]] = field(default_factory=dict)
    audit_path: str | None = None
    lease_ttl: float = 30.0
    audit: bool = True
    """False only when the file says ``audit = false``: `robostar serve` then keeps no audit
    log (it says so at start). With True and no ``audit_path``, the command picks the default
    file (:func:`default_audit_path`); a LineServer made in code audits only to a path given."""

    def __post_init__(self) -> None:
        seen: set[str] = set()
        for line in self.lines:
            if line.name in seen:
                raise ConfigError(f"lines.{line.name}: defined twice")
            seen.add(line.name)
        for name in self.faces:
            if name not in FACE_NAMES:
                known = ", ".join(sorted(FACE_NAMES))
                raise ConfigError(f"{name}: unknown section (faces: {known})")
        if not _seconds(self.lease_ttl):
            raise ConfigError(f"lease_ttl: {self.lease_ttl!r} is not a positive number of seconds")
        if not self.audit and self.audit_path:
            raise ConfigError("audit = false and audit_path: choose one")


def default_audit_path() -> Path:
    """Where `robostar serve` keeps its audit log when no path is given: the user's state
    folder (``~/.local/state/robostar/audit.jsonl`` on Linux). On by default: everything that
    moves a robot or writes to it is recorded unless the audit is turned off explicitly."""
    import platformdirs  # only `robostar serve` needs it

    return Path(platformdirs.user_state_dir("robostar")) / "audit.jsonl"


def _seconds(value: object, *, zero: bool = False) -> bool:
    """Whether ``value`` is a finite number of seconds, more than 0 (or 0 too, with ``zero``).

    TOML spells nan and inf, and ``nan <= 0`` is false: without the finiteness check a lease
    with a nan TTL never expires, and an inf interval never polls."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return False
    return value >= 0 if zero else value > 0


def parse_line_arg(text: str) -> LineConfig:
    """``NAME=URL`` (the ``--line`` option) -> a :class:`LineConfig` with the defaults."""
    name, sep, url = text.partition("=")
    if not sep or not name or not url:
        raise ConfigError(f"--line {text!r}: expected NAME=URL, e.g. cell1=/dev/ttyUSB0")
    return LineConfig(name=name, url=url)


_LINE_KEYS = {
    "url": str,
    "baudrate": int,
    "timeout": float,
    "poll_interval": float,
    "slow_interval": float,
    "history_interval": float,
    "poll_share": float,
    "rest_interval": float,
    "io_ports": list,
    "max_age": float,
    "channels": dict,
    "robot": str,
    "shared": list,
}


def _line(name: str, table: Any) -> LineConfig:
    where = f"lines.{name}"
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where}: expected a table with at least url = ...")
    kwargs: dict[str, Any] = {}
    for key, value in table.items():
        kind = _LINE_KEYS.get(key)
        if kind is None:
            raise ConfigError(f"{where}.{key}: unknown key (known: {', '.join(_LINE_KEYS)})")
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind) or isinstance(value, bool):
            raise ConfigError(f"{where}.{key}: {value!r} is not a {kind.__name__}")
        kwargs[key] = value
    if "url" not in kwargs:
        raise ConfigError(f"{where}.url: missing")
    if "io_ports" in kwargs:
        kwargs["io_ports"] = tuple(kwargs["io_ports"])
    if "shared" in kwargs:
        kwargs["shared"] = frozenset(str(scope) for scope in kwargs["shared"])
    if "channels" in kwargs:
        channels: dict[int, str] = {}
        for number, label in kwargs["channels"].items():
            if not str(number).isdigit():
                raise ConfigError(f"{where}.channels.{number}: not a channel number 1-3")
            channels[int(number)] = str(label)
        kwargs["channels"] = channels
    return LineConfig(name=name, **kwargs)


def config_from_mapping(data: Mapping[str, Any]) -> ServeConfig:
    """Validate parsed TOML: ``[lines.NAME]`` tables, face sections, audit_path, lease_ttl."""
    lines_table = data.get("lines", {})
    if not isinstance(lines_table, Mapping):
        raise ConfigError("lines: expected tables [lines.NAME]")
    lines = tuple(_line(str(name), table) for name, table in lines_table.items())
    faces: dict[str, dict[str, Any]] = {}
    audit_path: str | None = None
    audit = True
    lease_ttl = 30.0
    for key, value in data.items():
        if key == "lines":
            continue
        if key == "audit_path":
            if not isinstance(value, str):
                raise ConfigError(f"audit_path: {value!r} is not a path")
            audit_path = value
        elif key == "audit":
            if not isinstance(value, bool):
                raise ConfigError(f"audit: {value!r} is not true or false")
            audit = value
        elif key == "lease_ttl":
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise ConfigError(f"lease_ttl: {value!r} is not a number of seconds")
            lease_ttl = float(value)
        elif key in FACE_NAMES:
            if not isinstance(value, Mapping):
                raise ConfigError(f"{key}: expected a table [{key}]")
            faces[key] = dict(value)
        else:
            raise ConfigError(f"{key}: unknown key")
    return ServeConfig(
        lines=lines, faces=faces, audit_path=audit_path, lease_ttl=lease_ttl, audit=audit
    )


def load_config(path: str | Path) -> ServeConfig:
    """Read and validate a TOML file; :class:`ConfigError` names the key at fault."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror})") from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from exc
    return config_from_mapping(data)
