"""The MQTT face's settings: the ``[mqtt]`` section (docs/mqtt.md), every key checked."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

from robostar.errors import UsageError
from robostar.serve.faces.mqtt.commands import ESTOP, NAMES
from robostar.serve.faces.mqtt.topics import check_prefix

__all__ = ["MqttSettings", "SparkplugSettings", "settings_from"]

_OPTIONS = frozenset(
    (
        "url",
        "prefix",
        "client_id",
        "username",
        "password",
        "password_env",
        "ca",
        "cert",
        "key",
        "qos",
        "deadband",
        "rate",
        "buffer",
        "buffer_rows",
        "commands",
        "publish_timeout",
        "reconnect_max",
        "allow_remote",
        "token",
        "sparkplug",
    )
)
_SPARKPLUG_OPTIONS = frozenset(("group", "node", "primary_host"))
_COMMAND_OPTIONS = frozenset(("enabled", "allow", "estop", "max_pending", "max_payload"))


@dataclass(frozen=True)
class SparkplugSettings:
    """``[mqtt] sparkplug = { group = "...", node = "...", primary_host = "..." }``."""

    group: str
    node: str
    primary_host: str | None = None
    """The primary host application's id: the node is born only while its STATE says online."""


def _sparkplug_id(options: Mapping[str, Any], key: str) -> str:
    value = options.get(key)
    if not isinstance(value, str) or not value or any(c in value for c in "/+#\x00"):
        raise UsageError(
            f"mqtt.sparkplug.{key}: {value!r} is not a Sparkplug id (text without / + #)"
        )
    return value


def sparkplug_from(options: Any) -> SparkplugSettings | None:
    if options is None:
        return None
    if not isinstance(options, Mapping):
        raise UsageError("mqtt.sparkplug: expected a table (group, node, primary_host)")
    bad = sorted(set(options) - _SPARKPLUG_OPTIONS)
    if bad:
        raise UsageError(
            f"mqtt.sparkplug.{bad[0]}: unknown option ({', '.join(sorted(_SPARKPLUG_OPTIONS))})"
        )
    host = options.get("primary_host")
    return SparkplugSettings(
        group=_sparkplug_id(options, "group"),
        node=_sparkplug_id(options, "node"),
        primary_host=None if host is None else _sparkplug_id(options, "primary_host"),
    )


@dataclass(frozen=True)
class MqttSettings:
    host: str
    port: int
    tls: bool = False
    prefix: str = "robostar"
    client_id: str = "robostar"
    username: str | None = None
    password: str | None = field(default=None, repr=False)
    ca: str | None = None
    cert: str | None = None
    key: str | None = None
    qos: int = 1
    deadband: float = 0.01
    rate: float = 50.0
    buffer: str = ":memory:"
    buffer_rows: int = 100_000
    commands: frozenset[str] = frozenset()
    max_pending: int = 16
    """Commands per line waiting or running in the face (stops count apart); past it: busy."""
    max_payload: int = 16_384
    """The largest command payload read (bytes); a bigger one is refused unread."""
    publish_timeout: float = 5.0
    reconnect_max: float = 30.0
    """The longest wait between reconnection attempts (the wait doubles from 0.5 s)."""
    sparkplug: SparkplugSettings | None = None
    """Sparkplug B beside the JSON tree (None: the JSON tree alone)."""


def _number(options: Mapping[str, Any], key: str, default: float, low: float) -> float:
    value = options.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float) or not value >= low:
        raise UsageError(f"mqtt.{key}: {value!r} is not a number of at least {low:g}")
    return float(value)


def _count(options: Mapping[str, Any], key: str, default: int, low: int) -> int:
    value = options.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise UsageError(f"mqtt.commands.{key}: {value!r} is not an integer of at least {low}")
    return value


def settings_from(options: Mapping[str, Any]) -> MqttSettings:
    """The face's settings, every key checked (UsageError naming it)."""
    unknown = sorted(set(options) - _OPTIONS)
    if unknown:
        raise UsageError(
            f"mqtt.{unknown[0]}: unknown option (options: {', '.join(sorted(_OPTIONS))})"
        )
    url = str(options.get("url", ""))
    parts = urlsplit(url)
    if parts.scheme not in ("mqtt", "mqtts") or not parts.hostname:
        raise UsageError(f"mqtt.url: {url!r} is not mqtt://HOST[:PORT] or mqtts://HOST[:PORT]")
    tls = parts.scheme == "mqtts"
    try:
        port = parts.port or (8883 if tls else 1883)
    except ValueError:
        raise UsageError(f"mqtt.url: {url!r} has a bad port") from None
    password = options.get("password")
    env = options.get("password_env")
    if env is not None:
        password = os.environ.get(str(env))
        if password is None:
            raise UsageError(f"mqtt.password_env: the environment has no {env}")
    commands_option = options.get("commands", {})
    if not isinstance(commands_option, Mapping):
        raise UsageError("mqtt.commands: expected a table (enabled, allow, estop)")
    bad = sorted(set(commands_option) - _COMMAND_OPTIONS)
    if bad:
        raise UsageError(
            f"mqtt.commands.{bad[0]}: unknown option ({', '.join(sorted(_COMMAND_OPTIONS))})"
        )
    commands: set[str] = set()
    if commands_option.get("enabled", False) is True:
        allow = commands_option.get("allow", [])
        if isinstance(allow, str) or not all(name in NAMES for name in allow):
            raise UsageError(
                f"mqtt.commands.allow: {allow!r}: names among {', '.join(sorted(NAMES))}"
            )
        commands.update(allow)
        if commands_option.get("estop", False) is True:
            commands.add(ESTOP)
    cert, key, ca = options.get("cert"), options.get("key"), options.get("ca")
    if (cert or key) and not (tls or ca):
        # Only mqtts:// or ca turn TLS on: a certificate on an mqtt:// URL would be silently
        # unused, and the face would connect in clear, its password too.
        # (Named by host and port only: the URL may hold a password.)
        raise UsageError(
            f"mqtt.{'cert' if cert else 'key'}: client certificates need TLS: use"
            f" mqtts://{parts.hostname}:{port} (or set mqtt.ca); an mqtt:// URL connects in clear"
        )
    if key and not cert:
        raise UsageError("mqtt.key: a key without mqtt.cert (the client certificate) is unused")
    qos = options.get("qos", 1)
    if qos not in (0, 1, 2):
        raise UsageError(f"mqtt.qos: {qos!r} is not 0, 1 or 2")
    return MqttSettings(
        host=parts.hostname,
        port=port,
        tls=tls or bool(ca),
        prefix=check_prefix(str(options.get("prefix", "robostar"))),
        client_id=str(options.get("client_id", "robostar")),
        username=options.get("username") or parts.username,
        password=password or parts.password,
        ca=ca,
        cert=cert,
        key=key,
        qos=int(qos),
        deadband=_number(options, "deadband", 0.01, 0.0),
        rate=_number(options, "rate", 50.0, 0.1),
        buffer=str(options.get("buffer", ":memory:")),
        buffer_rows=int(_number(options, "buffer_rows", 100_000, 1)),
        commands=frozenset(commands),
        max_pending=_count(commands_option, "max_pending", 16, 1),
        max_payload=_count(commands_option, "max_payload", 16_384, 16),
        publish_timeout=_number(options, "publish_timeout", 5.0, 0.1),
        reconnect_max=_number(options, "reconnect_max", 30.0, 0.1),
        sparkplug=sparkplug_from(options.get("sparkplug")),
    )
