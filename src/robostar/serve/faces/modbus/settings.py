"""The ``[modbus]`` section of the line server's configuration, checked key by key.

```toml
[modbus]
lines = { cell1 = "127.0.0.1:5020" }     # a port per line (--modbus cell1=127.0.0.1:5020)
# allow_remote = true                    # beyond loopback: then allow_from names the PLCs
# allow_from = ["192.0.2.7"]             # addresses and networks served (loopback always is)
holder = "plc"                           # the lease holder's name in the audit log
globals = { int = { first = 0, count = 16 }, float = { first = 0, count = 8 } }
globals_interval = 1.0                   # seconds between the face's reads of the globals
max_clients = 16                         # connections per line's port; more are closed at once
idle_timeout = 120                       # seconds of silence that close a connection (0: never)

[modbus.commands]
enabled = true                           # off by default: the command registers are read-only
allow = ["run_job", "stop_job", "servo", "reset_alarms"]
```
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from robostar.commands.variables import ReadGlobalFloat, ReadGlobalInt
from robostar.errors import UsageError
from robostar.listen import Network, is_loopback, parse_listen, parse_networks
from robostar.serve.faces.modbus.handshake import NAMES, STOP_NAMES
from robostar.serve.faces.modbus.layout import MAX_GLOBALS, GlobalRange

__all__ = ["DEFAULT_ALLOW", "ModbusSettings", "settings_from"]

_OPTIONS = frozenset(
    (
        "lines",
        "allow_remote",
        "allow_from",
        "token",
        "holder",
        "globals",
        "globals_interval",
        "commands",
        "max_clients",
        "idle_timeout",
    )
)
_COMMAND_OPTIONS = frozenset(("enabled", "allow"))
DEFAULT_ALLOW = tuple(sorted(STOP_NAMES))
"""With commands enabled and no allowlist: the stops only."""


@dataclass(frozen=True)
class ModbusSettings:
    lines: dict[str, tuple[str, int]]
    allow_remote: bool = False
    allow_from: tuple[Network, ...] | None = None
    """The peers served beside loopback (None: any, which only a loopback listener may be)."""
    holder: str = "plc"
    ints: GlobalRange = field(default_factory=GlobalRange)
    floats: GlobalRange = field(default_factory=GlobalRange)
    globals_interval: float = 1.0
    commands: frozenset[str] = frozenset()
    """The commands the PLC may run (empty: writes are off, the command block is read-only)."""
    max_clients: int = 16
    """Connections per line's port at once; one more is closed as soon as it opens."""
    idle_timeout: float = 120.0
    """Seconds after which a connection that sent nothing is closed (0: never)."""

    @property
    def writes(self) -> bool:
        return bool(self.commands)


def _range(
    table: Any, kind: str, command: type[ReadGlobalInt] | type[ReadGlobalFloat]
) -> GlobalRange:
    if table is None:
        return GlobalRange()
    where = f"modbus.globals.{kind}"
    if not isinstance(table, Mapping) or set(table) - {"first", "count"}:
        raise UsageError(f"{where}: expected {{ first = INDEX, count = N }}")
    first, count = table.get("first", 0), table.get("count", 0)
    for key, value in (("first", first), ("count", count)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise UsageError(f"{where}.{key}: {value!r} is not a whole number of 0 or more")
    if count > MAX_GLOBALS:
        raise UsageError(f"{where}.count: {count} is over {MAX_GLOBALS}")
    if count:
        for index in (first, first + count - 1):
            try:
                command(index).encode()
            except UsageError as exc:
                raise UsageError(f"{where}: {exc}") from None
    return GlobalRange(first, count)


def settings_from(options: Mapping[str, Any], line_names: set[str] | None = None) -> ModbusSettings:
    """The face's settings (UsageError naming the key at fault)."""
    unknown = sorted(set(options) - _OPTIONS)
    if unknown:
        raise UsageError(
            f"modbus.{unknown[0]}: unknown option (options: {', '.join(sorted(_OPTIONS))})"
        )
    lines_option = options.get("lines", {})
    if not isinstance(lines_option, Mapping) or not lines_option:
        raise UsageError('modbus.lines: expected NAME = "HOST:PORT" for at least one line')
    allow_remote = options.get("allow_remote", False)
    if not isinstance(allow_remote, bool):
        raise UsageError(f"modbus.allow_remote: {allow_remote!r} is not true or false")
    allow_from_option = options.get("allow_from")
    allow_from = (
        None
        if allow_from_option is None
        else parse_networks(allow_from_option, "modbus.allow_from")
    )
    lines: dict[str, tuple[str, int]] = {}
    for name, listen in lines_option.items():
        if line_names is not None and name not in line_names:
            known = ", ".join(sorted(line_names))
            raise UsageError(f"modbus.lines.{name}: no such line (lines: {known})")
        lines[str(name)] = parse_listen(str(listen))
        host = lines[str(name)][0]
        if not is_loopback(host) and not allow_remote:
            raise UsageError(
                f"modbus.lines.{name}: {host} is not a loopback address, and Modbus TCP has no"
                " authentication; set allow_remote = true (--allow-remote) to serve other"
                " machines (then only on a network the cell's PLC alone can reach)"
            )
        if not is_loopback(host) and allow_from is None:
            raise UsageError(
                f"modbus.lines.{name}: {host} is beyond loopback, and Modbus TCP has no"
                ' authentication: name the PLCs served (modbus.allow_from = ["192.0.2.7",'
                ' "10.1.0.0/16"])'
            )
    holder = options.get("holder", "plc")
    if not isinstance(holder, str) or not holder:
        raise UsageError(f"modbus.holder: {holder!r} is not a name")
    table = options.get("globals", {})
    if not isinstance(table, Mapping) or set(table) - {"int", "float"}:
        raise UsageError("modbus.globals: expected a table with int = {...} and float = {...}")
    interval = options.get("globals_interval", 1.0)
    if isinstance(interval, bool) or not isinstance(interval, int | float) or not interval >= 0.1:
        raise UsageError(f"modbus.globals_interval: {interval!r} is not 0.1 s or more")
    max_clients = options.get("max_clients", 16)
    if isinstance(max_clients, bool) or not isinstance(max_clients, int) or max_clients < 1:
        raise UsageError(f"modbus.max_clients: {max_clients!r} is not a whole number of 1 or more")
    idle = options.get("idle_timeout", 120.0)
    if isinstance(idle, bool) or not isinstance(idle, int | float) or not idle >= 0:
        raise UsageError(f"modbus.idle_timeout: {idle!r} is not a number of seconds (0: never)")
    return ModbusSettings(
        lines=lines,
        max_clients=max_clients,
        idle_timeout=float(idle),
        allow_remote=allow_remote,
        allow_from=allow_from,
        holder=holder,
        ints=_range(table.get("int"), "int", ReadGlobalInt),
        floats=_range(table.get("float"), "float", ReadGlobalFloat),
        globals_interval=float(interval),
        commands=_commands(options.get("commands", {})),
    )


def _commands(table: Any) -> frozenset[str]:
    if not isinstance(table, Mapping):
        raise UsageError("modbus.commands: expected a table (enabled, allow)")
    bad = sorted(set(table) - _COMMAND_OPTIONS)
    if bad:
        raise UsageError(f"modbus.commands.{bad[0]}: unknown option (enabled, allow)")
    enabled = table.get("enabled", False)
    if not isinstance(enabled, bool):
        raise UsageError(f"modbus.commands.enabled: {enabled!r} is not true or false")
    allow = table.get("allow", list(DEFAULT_ALLOW))
    if isinstance(allow, str) or not isinstance(allow, list) or not all(n in NAMES for n in allow):
        raise UsageError(
            f"modbus.commands.allow: {allow!r}: names among {', '.join(sorted(NAMES))}"
        )
    starts = sorted({"run_job", "start_job"} & set(allow))
    if starts and "stop_job" not in allow:
        raise UsageError(
            f"modbus.commands.allow: {' and '.join(starts)} without stop_job: a PLC that can"
            " start a JOB must be able to stop it"
        )
    return frozenset(allow) if enabled else frozenset()
