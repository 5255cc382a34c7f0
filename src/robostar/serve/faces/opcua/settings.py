"""The ``[opcua]`` section of the line server's configuration, checked key by key."""

from __future__ import annotations

import socket
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import platformdirs

from robostar.commands.variables import ReadGlobalFloat, ReadGlobalInt
from robostar.errors import UsageError
from robostar.listen import is_loopback, parse_listen
from robostar.transport.url import netloc

__all__ = ["OpcUaSettings", "settings_from"]

_OPTIONS = frozenset(
    (
        "listen",
        "users",
        "allow_anonymous_read",
        "allow_remote",
        "token",
        "state_dir",
        "cache_dir",
        "application_uri",
        "hostname",
        "globals",
        "globals_interval",
        "pki_dir",
        "accept_unknown_clients",
    )
)


@dataclass(frozen=True)
class OpcUaSettings:
    host: str
    port: int
    users: Path | None
    """The users file (``robostar serve user add``); None: nobody can sign in."""
    allow_anonymous_read: bool
    state_dir: Path
    """Where the application certificate and its key are kept."""
    cache_dir: Path | None
    """Where the imported nodesets are cached (None: import them at every start)."""
    application_uri: str
    hostname: str
    """The host name in the certificate and the endpoint URL clients are told."""
    global_ints: tuple[int, ...] = ()
    global_floats: tuple[int, ...] = ()
    """The global variables the face reads (GR) for every line; the line server polls none."""
    globals_interval: float = 1.0
    pki_dir: Path | None = None
    """The client trust list's folder (trusted/, rejected/); None: ``<state_dir>/pki``."""
    accept_unknown_clients: bool = False
    """Accept client applications whose certificate is not in ``trusted/``."""

    @property
    def pki(self) -> Path:
        return self.pki_dir if self.pki_dir is not None else self.state_dir / "pki"

    @property
    def endpoint(self) -> str:
        return self.url(self.port)

    def url(self, port: int) -> str:
        """``opc.tcp://HOST:PORT/`` for this host (an IPv6 address in brackets)."""
        return f"opc.tcp://{netloc(self.host, port)}/"


def _flag(options: Mapping[str, Any], key: str) -> bool:
    value = options.get(key, False)
    if not isinstance(value, bool):
        raise UsageError(f"opcua.{key}: {value!r} is not true or false")
    return value


def settings_from(options: Mapping[str, Any]) -> OpcUaSettings:
    """The face's settings (UsageError naming the key at fault)."""
    unknown = sorted(set(options) - _OPTIONS)
    if unknown:
        raise UsageError(
            f"opcua.{unknown[0]}: unknown option (options: {', '.join(sorted(_OPTIONS))})"
        )
    host, port = parse_listen(str(options.get("listen", "127.0.0.1:4840")))
    loopback = is_loopback(host)
    if not loopback and not _flag(options, "allow_remote"):
        raise UsageError(
            f"opcua.listen: {host} is not a loopback address; set allow_remote = true"
            " (--allow-remote) to serve other machines"
        )
    anonymous = _flag(options, "allow_anonymous_read")
    if anonymous and not loopback:
        raise UsageError(
            "opcua.allow_anonymous_read: only on a loopback address (it opens an unsigned,"
            " read-only endpoint for local tools)"
        )
    users = options.get("users")
    if users is not None and not isinstance(users, str):
        raise UsageError(f"opcua.users: {users!r} is not a path")
    if users is None and not anonymous:
        raise UsageError(
            "opcua.users: no users file, and anonymous reading is off: nobody could sign in"
            " (add users with `robostar serve user add NAME --role operator --users FILE`,"
            " or --opcua-allow-anonymous-read on loopback)"
        )
    state = options.get("state_dir")
    state_dir = Path(state) if state else Path(platformdirs.user_data_dir("robostar")) / "opcua"
    cache = options.get("cache_dir", None)
    if cache is False:
        cache_dir = None
    elif cache:
        cache_dir = Path(str(cache))
    else:
        cache_dir = Path(platformdirs.user_cache_dir("robostar")) / "opcua"
    global_ints, global_floats = _globals(options.get("globals", {}))
    interval = options.get("globals_interval", 1.0)
    if isinstance(interval, bool) or not isinstance(interval, int | float) or interval < 0.1:
        raise UsageError(f"opcua.globals_interval: {interval!r} is not 0.1 s or more")
    pki = options.get("pki_dir")
    if pki is not None and not isinstance(pki, str):
        raise UsageError(f"opcua.pki_dir: {pki!r} is not a path")
    hostname = str(options.get("hostname") or socket.gethostname())
    uri = str(options.get("application_uri") or f"urn:{hostname}:robostar:serve")
    return OpcUaSettings(
        host=host,
        port=port,
        users=Path(users) if users is not None else None,
        allow_anonymous_read=anonymous,
        state_dir=state_dir,
        cache_dir=cache_dir,
        application_uri=uri,
        hostname=hostname,
        global_ints=global_ints,
        global_floats=global_floats,
        globals_interval=float(interval),
        pki_dir=Path(pki) if pki else None,
        accept_unknown_clients=_flag(options, "accept_unknown_clients"),
    )


def _globals(table: Any) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """``{int = [0, 1], float = [0]}``: indices checked as GR would check them."""
    if not isinstance(table, Mapping) or set(table) - {"int", "float"}:
        raise UsageError("opcua.globals: expected a table with int = [...] and float = [...]")
    chosen: dict[str, tuple[int, ...]] = {}
    for kind, command in (("int", ReadGlobalInt), ("float", ReadGlobalFloat)):
        indices = table.get(kind, [])
        if isinstance(indices, str) or not all(
            isinstance(i, int) and not isinstance(i, bool) for i in indices
        ):
            raise UsageError(f"opcua.globals.{kind}: {indices!r} is not a list of indices")
        for index in indices:
            try:
                command(index).encode()
            except UsageError as exc:
                raise UsageError(f"opcua.globals.{kind}: {exc}") from None
        chosen[kind] = tuple(sorted(set(indices)))
    return chosen["int"], chosen["float"]
