"""Transport URLs: which kind of pipe a string names, and its options as typed values.

Accepted forms::

    /dev/ttyUSB0  COM3                     a serial device (115200 8N1, no flow control)
    serial:///dev/ttyUSB0?baudrate=57600   the same, with options in the query
    tcp://192.0.2.10:20000                 a TCP socket (a serial-to-Ethernet gateway)
    socket://  rfc2217://  loop://         pyserial's own URL handlers
    sim://?channels=2&robot=scara          the built-in simulator, in this process
    serve://127.0.0.1:8470/cell1           a line of a robostar serve process (its local API)
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import parse_qsl, urlsplit

from robostar.errors import UsageError

__all__ = [
    "DEFAULT_BAUDRATE",
    "DEFAULT_TCP_PORT",
    "SERIAL_OPTIONS",
    "SERVE_OPTIONS",
    "TCP_OPTIONS",
    "Endpoint",
    "Kind",
    "coerce_options",
    "netloc",
    "parse_url",
]

DEFAULT_BAUDRATE = 115200
"""The N1's factory setting (manual 3.5)."""
DEFAULT_TCP_PORT = 20000
"""The port serial-to-Ethernet gateways for the N1 are commonly set to."""

_PYSERIAL_SCHEMES = frozenset(("socket", "rfc2217", "loop", "spy", "hwgrep", "alt"))


class Kind(enum.Enum):
    SERIAL = "serial"
    PYSERIAL_URL = "pyserial"
    TCP = "tcp"
    SIM = "sim"
    SERVE = "serve"


@dataclass(frozen=True)
class Endpoint:
    """A parsed transport URL.

    ``target`` is the device path (SERIAL), the whole URL (PYSERIAL_URL), ``host`` (TCP) or the
    raw query (SIM). ``options`` are the query's and the caller's options, caller's last.
    """

    url: str
    kind: Kind
    target: str
    port: int = 0
    options: Mapping[str, object] = field(default_factory=dict)


def _bool(value: object) -> bool:
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in ("1", "true", "yes", "on"):
        return True
    if text in ("0", "false", "no", "off"):
        return False
    raise ValueError(f"{value!r} is not a yes/no value")


def _parity(value: object) -> str:
    text = str(value).strip().upper()[:1]
    if text not in ("N", "E", "O", "M", "S"):
        raise ValueError(f"{value!r} is not N, E, O, M or S")
    return text


def _positive_float(value: object) -> float:
    number = float(str(value)) if not isinstance(value, int | float) else float(value)
    if not number > 0:
        raise ValueError(f"{value!r} is not a positive number")
    return number


def _seconds(value: object) -> float:
    number = float(str(value)) if not isinstance(value, int | float) else float(value)
    if not 0 <= number < math.inf:
        raise ValueError(f"{value!r} is not a number of seconds, 0 or more")
    return number


def _int(value: object) -> int:
    if isinstance(value, bool):
        raise ValueError(f"{value!r} is not an integer")
    return value if isinstance(value, int) else int(str(value))


SERIAL_OPTIONS: dict[str, Callable[[object], object]] = {
    "baudrate": _int,
    "bytesize": _int,
    "parity": _parity,
    "stopbits": _positive_float,
    "rtscts": _bool,
    "xonxoff": _bool,
    "dsrdtr": _bool,
    "exclusive": _bool,
    "low_latency": _bool,
}
"""Options of a serial device, with their converters."""

TCP_OPTIONS: dict[str, Callable[[object], object]] = {"connect_timeout": _positive_float}
SERVE_OPTIONS: dict[str, Callable[[object], object]] = {
    "connect_timeout": _positive_float,
    "token": str,
    "max_age": _seconds,
}


def coerce_options(
    url: str, options: Mapping[str, object], table: Mapping[str, Callable[[object], object]]
) -> dict[str, Any]:
    """Typed option values; UsageError naming the option that is unknown or malformed."""
    result: dict[str, Any] = {}
    for name, value in options.items():
        convert = table.get(name)
        if convert is None:
            known = ", ".join(sorted(table)) or "none"
            raise UsageError(f"{url}: unknown option {name!r} (known: {known})")
        try:
            result[name] = convert(value)
        except (TypeError, ValueError) as exc:
            raise UsageError(f"{url}: option {name}: {exc}") from None
    return result


def netloc(host: str, port: int) -> str:
    """``HOST:PORT`` as a URL writes it: an IPv6 address in brackets (:func:`parse_url` gives
    the host without them)."""
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def parse_url(url: str, options: Mapping[str, object] | None = None) -> Endpoint:
    """Parse a transport URL; UsageError naming the argument if it is not one."""
    if not isinstance(url, str) or not url.strip():
        raise UsageError(f"url must be a device path or a URL, not {url!r}")
    extra = dict(options or {})
    scheme, sep, rest = url.partition("://")
    if not sep:
        return Endpoint(url, Kind.SERIAL, url, options=extra)
    scheme = scheme.lower()
    if scheme == "serial":
        path, _, query = rest.partition("?")
        if not path:
            raise UsageError(f"url {url!r}: serial:// needs a device, e.g. serial:///dev/ttyUSB0")
        return Endpoint(url, Kind.SERIAL, path, options={**dict(parse_qsl(query)), **extra})
    if scheme in ("tcp", "serve"):
        try:
            parts = urlsplit(url)
            port = parts.port or (DEFAULT_TCP_PORT if scheme == "tcp" else 8470)
        except ValueError as exc:
            # urlsplit refuses e.g. an unclosed [ of an IPv6 address; .port a bad number
            bad_port = "port" in str(exc).lower()
            reason = "the port is not a number 1-65535" if bad_port else str(exc)
            raise UsageError(f"url {url!r}: {reason}") from None
        merged = {**dict(parse_qsl(parts.query)), **extra}
        if scheme == "tcp":
            if not parts.hostname:
                raise UsageError(f"url {url!r}: tcp:// needs a host, e.g. tcp://192.0.2.10:20000")
            return Endpoint(url, Kind.TCP, parts.hostname, port, merged)
        line = parts.path.strip("/")
        if not parts.hostname or not line:
            raise UsageError(
                f"url {url!r}: serve:// needs HOST:PORT/LINE, e.g. serve://127.0.0.1:8470/cell1"
            )
        return Endpoint(url, Kind.SERVE, parts.hostname, port, {"line": line, **merged})
    if scheme == "sim":
        _, _, query = rest.partition("?")
        merged = {**dict(parse_qsl(query, keep_blank_values=True)), **extra}
        return Endpoint(url, Kind.SIM, query, options=merged)
    if scheme in _PYSERIAL_SCHEMES:
        return Endpoint(url, Kind.PYSERIAL_URL, url, options=extra)
    raise UsageError(
        f"url {url!r}: unknown scheme {scheme!r}; use a device path, serial://, tcp://, sim://,"
        " serve://,"
        " or a pyserial URL (socket://, rfc2217://, loop://)"
    )
