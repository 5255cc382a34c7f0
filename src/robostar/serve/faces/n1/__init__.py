"""The N1 face: the unchanged N1 host protocol (controller role) on a TCP port per line.

See :mod:`robostar.serve.faces.n1.backend` for how sessions, the queue and the lease meet.

The N1 protocol carries no credentials, so a port beyond loopback must say who may use it: the
hosts allowed (``allow_from``, for host programs that speak plain TCP, as every existing one
does) and/or mutual TLS (``tls_cert`` + ``tls_key`` + ``client_ca``: only peers with a
certificate signed by that CA get a session; a legacy host reaches it through a TLS tunnel).
"""

from __future__ import annotations

import math
import ssl
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from robostar.controller_role.limits import HostLimits
from robostar.errors import UsageError
from robostar.listen import is_loopback, parse_listen, parse_networks
from robostar.serve.faces.n1.face import N1Face

if TYPE_CHECKING:
    from robostar.serve.line_server import LineServer

__all__ = ["N1Face", "create", "mutual_tls_context"]

_OPTIONS = frozenset(
    (
        "lines",
        "allow_remote",
        "token",
        "allow_from",
        "tls_cert",
        "tls_key",
        "client_ca",
        "max_clients",
        "idle_timeout",
        "max_age",
    )
)


def mutual_tls_context(cert: str, key: str, client_ca: str) -> ssl.SSLContext:
    """A server context that requires a client certificate signed by ``client_ca`` (TLS ≥ 1.2)."""
    try:
        context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH, cafile=client_ca)
        context.load_cert_chain(cert, key)
    except (OSError, ssl.SSLError) as exc:
        raise UsageError(f"n1: cannot load the TLS files ({exc})") from None
    context.minimum_version = ssl.TLSVersion.TLSv1_2
    context.verify_mode = ssl.CERT_REQUIRED
    return context


def create(server: LineServer, options: Mapping[str, Any]) -> N1Face:
    """``options``: ``{"lines": {NAME: "HOST:PORT"}, "allow_remote": bool, "allow_from": [...],
    "tls_cert": PATH, "tls_key": PATH, "client_ca": PATH, "max_clients": N (16),
    "idle_timeout": SECONDS (600; 0 never), "max_age": SECONDS (reads answered from the model
    when at most that old; default none: every read is linearizable)}``."""
    unknown = sorted(set(options) - _OPTIONS)
    if unknown:
        raise UsageError(
            f"n1.{unknown[0]}: unknown option (options: {', '.join(sorted(_OPTIONS))})"
        )
    lines = options.get("lines", {})
    if not isinstance(lines, Mapping) or not lines:
        raise UsageError('n1.lines: expected NAME = "HOST:PORT" for at least one line')
    tls_files = [options.get(key) for key in ("tls_cert", "tls_key", "client_ca")]
    context = None
    if any(tls_files):
        if not all(isinstance(f, str) and f for f in tls_files):
            raise UsageError("n1: mutual TLS needs all of tls_cert, tls_key and client_ca")
        cert, key, ca = (str(f) for f in tls_files)
        context = mutual_tls_context(cert, key, ca)
    allow_from = options.get("allow_from")
    networks = None if allow_from is None else parse_networks(allow_from, "n1.allow_from")
    listens: dict[str, tuple[str, int]] = {}
    for name, listen in lines.items():
        if name not in server.lines:
            raise UsageError(f"n1.lines.{name}: no such line (lines: {', '.join(server.lines)})")
        listens[name] = parse_listen(str(listen))
        host = listens[name][0]
        if context is None and networks is None and not is_loopback(host):
            raise UsageError(
                f"n1.lines.{name}: {host} is beyond loopback, and the N1 protocol has no "
                'authentication: name the hosts allowed (n1.allow_from = ["192.0.2.7", '
                '"10.1.0.0/16"]) or require client certificates (n1.tls_cert, n1.tls_key, '
                "n1.client_ca)"
            )
    return N1Face(
        server,
        listens,
        bool(options.get("allow_remote", False)),
        ssl_context=context,
        allow_from=networks,
        limits=HostLimits.from_options(options, "n1"),
        max_age=_max_age(options.get("max_age")),
    )


def _max_age(value: object) -> float | None:
    """The ``max_age`` option: None, or a finite number of seconds, 0 or more."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 <= value < math.inf:
        raise UsageError(f"n1.max_age: {value!r} is not a number of seconds, 0 or more")
    return float(value)
