"""``robostar serve``: own the controllers' lines and serve them through the configured faces."""

from __future__ import annotations

import asyncio
import json
import logging
import os
import signal
import sys
import time
from collections.abc import Mapping
from typing import Any

import click

from robostar.cli.serve_modbus import modbus_map
from robostar.cli.serve_users import user
from robostar.errors import UsageError
from robostar.serve.config import (
    ConfigError,
    LineConfig,
    ServeConfig,
    config_from_mapping,
    default_audit_path,
    load_config,
    parse_line_arg,
)
from robostar.transport.url import netloc

__all__ = ["serve"]

log = logging.getLogger("robostar.serve")


class _JsonLines(logging.Formatter):
    """One JSON object per log record: easy to grep, easy for journald and log shippers."""

    def format(self, record: logging.LogRecord) -> str:
        entry: dict[str, Any] = {
            "at": round(record.created, 3),
            "level": record.levelname.lower(),
            "logger": record.name,
            "msg": record.getMessage(),
        }
        if record.exc_info:
            entry["error"] = self.formatException(record.exc_info)
        return json.dumps(entry, ensure_ascii=False)


def _pair(option: str, text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name or not value:
        raise ConfigError(f"{option} {text!r}: expected NAME=HOST:PORT")
    return name, value


def build_config(
    config_file: str | None,
    lines: tuple[str, ...],
    n1: tuple[str, ...],
    faces: dict[str, str | None],
    allow_remote: bool,
    token: str | None,
    audit: str | None,
    no_audit: bool = False,
    modbus: tuple[str, ...] = (),
) -> ServeConfig:
    """The file's configuration (if any) with the command line's lines and faces on top.

    The audit log is on unless turned off (``--no-audit`` or ``audit = false``): without a
    path from ``--audit`` or ``audit_path`` it goes to :func:`default_audit_path`."""
    base = load_config(config_file) if config_file else config_from_mapping({})
    all_lines: dict[str, LineConfig] = {lc.name: lc for lc in base.lines}
    for text in lines:
        lc = parse_line_arg(text)
        all_lines[lc.name] = lc
    sections = {name: dict(options) for name, options in base.faces.items()}
    for face, option, pairs in (("n1", "--n1", n1), ("modbus", "--modbus", modbus)):
        if pairs:
            face_lines = dict(sections.get(face, {}).get("lines", {}))
            face_lines.update(_pair(option, text) for text in pairs)
            sections.setdefault(face, {})["lines"] = face_lines
    for name, value in faces.items():
        if value is not None:
            key = "url" if name == "mqtt" else "listen"
            sections.setdefault(name, {})[key] = value
    for options in sections.values():
        if allow_remote:
            options["allow_remote"] = True
        if token is not None:
            options["token"] = token
    if not all_lines:
        raise ConfigError("lines: none given (--line NAME=URL or [lines.NAME] in --config)")
    if no_audit and audit:
        raise UsageError("--audit FILE and --no-audit: choose one")
    # the command line wins over the file, as for every setting: --audit FILE keeps a log
    # even where the file says audit = false
    keep = not no_audit and (base.audit or bool(audit))
    path = (audit or base.audit_path or str(default_audit_path())) if keep else None
    return ServeConfig(
        lines=tuple(all_lines.values()),
        faces=sections,
        audit_path=path,
        lease_ttl=base.lease_ttl,
        audit=keep,
    )


def _check_faces(config: ServeConfig) -> None:
    """Make each face from its options (checking them, naming the bad key) without starting
    it: nothing is opened, nothing listens."""
    from robostar.serve import LineServer
    from robostar.serve.faces import create_face

    server = LineServer(config)
    for name, options in config.faces.items():
        create_face(name, server, options)


def without_password(url: str) -> str:
    """``url`` with the password of its user part (``mqtt://user:secret@host``) shown as
    ``***``: the start's summary goes to the service's journal, where no secret belongs."""
    # by the text, not urlsplit: a password holding "/", "?" or "#" ends urlsplit's netloc early
    scheme, sep, rest = url.partition("://")
    userinfo, at, host = rest.rpartition("@")
    if not sep or not at or ":" not in userinfo:
        return url
    user = userinfo.partition(":")[0]
    return f"{scheme}://{user}:***@{host}"


def serving(name: str, face: object, options: Mapping[str, Any]) -> str:
    """The start's line for a face: where it listens (its bound addresses, port 0 resolved) or,
    for a face that connects out (MQTT), where to, its password hidden."""
    where: Any = getattr(face, "addresses", None) or getattr(face, "address", None)
    if isinstance(where, Mapping):
        text = ", ".join(f"{line} on {netloc(*address)}" for line, address in where.items())
    elif isinstance(where, tuple | list) and len(where) == 2:
        text = netloc(str(where[0]), int(where[1]))
    else:
        url = options.get("url") or options.get("listen")
        text = without_password(url) if isinstance(url, str) else "on"
    return f"serving {name}: {text}"


def _describe(config: ServeConfig) -> list[str]:
    out = [f"line {lc.name}: {lc.url} (poll every {lc.poll_interval:g} s)" for lc in config.lines]
    for name, options in config.faces.items():
        where = options.get("listen") or options.get("url") or options.get("lines")
        if isinstance(where, str):
            where = without_password(where)
        out.append(f"face {name}: {where}")
    if config.audit_path:
        out.append(f"audit log: {config.audit_path}")
    elif not config.audit:
        out.append("audit log: OFF (turned off): state changes are not recorded")
    return out


async def _run(config: ServeConfig) -> None:
    from robostar.serve.line_server import LineServer

    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    server = LineServer(config)
    await server.start()
    try:
        for name, line in server.lines.items():
            state = "up" if line.up else f"DOWN ({line.health.last_error})"
            log.info("line %s %s", name, state)
        for name, face in server.faces.items():
            click.echo(serving(name, face, config.faces.get(name, {})), err=True)
        click.echo("ready; Ctrl-C or SIGTERM stops", err=True)
        await stop.wait()
        log.info("stopping: jogs are stopped, queued requests fail")
        started = time.monotonic()
    finally:
        await asyncio.wait_for(server.stop(), 10)
    log.info("stopped in %.2f s", time.monotonic() - started)


@click.group(invoke_without_command=True)
@click.option(
    "--line", "lines", multiple=True, metavar="NAME=URL", help="A line to own (repeatable)."
)
@click.option("--config", "config_file", type=click.Path(dir_okay=False), help="A TOML file.")
@click.option(
    "--check",
    "check_file",
    type=click.Path(dir_okay=False),
    metavar="CONFIG",
    help="Validate CONFIG without opening any line, and exit.",
)
@click.option("--n1", multiple=True, metavar="NAME=HOST:PORT", help="Serve line NAME as an N1.")
@click.option(
    "--modbus",
    multiple=True,
    metavar="NAME=HOST:PORT",
    help="Serve line NAME to a PLC (Modbus TCP).",
)
@click.option("--api", metavar="HOST:PORT", help="The local JSON API.")
@click.option("--metrics", metavar="HOST:PORT", help="Prometheus metrics at /metrics.")
@click.option("--mqtt", metavar="URL", help="Publish to an MQTT broker.")
@click.option("--opcua", metavar="HOST:PORT", help="Serve OPC UA (Robotics companion spec).")
@click.option(
    "--opcua-allow-anonymous-read",
    is_flag=True,
    help="Also an unsigned, read-only OPC UA endpoint for local tools (loopback only).",
)
@click.option("--web", metavar="HOST:PORT", help="Serve the web dashboard.")
@click.option(
    "--audit",
    metavar="FILE",
    help="Append every state change to FILE (JSONL; default: the user's state folder).",
)
@click.option("--no-audit", is_flag=True, help="Keep no audit log (said at start).")
@click.option("--allow-remote", is_flag=True, help="Allow binding beyond loopback (needs --token).")
@click.option(
    "--token",
    envvar="ROBOSTAR_SERVE_TOKEN",
    metavar="TOKEN",
    help="Token remote consumers must present (or ROBOSTAR_SERVE_TOKEN).",
)
@click.option(
    "--log-format", type=click.Choice(["json", "text"]), default="json", show_default=True
)
@click.option("-v", "--verbose", is_flag=True, help="Log debug detail.")
@click.pass_context
def serve(
    ctx: click.Context,
    lines: tuple[str, ...],
    config_file: str | None,
    check_file: str | None,
    n1: tuple[str, ...],
    modbus: tuple[str, ...],
    api: str | None,
    metrics: str | None,
    mqtt: str | None,
    opcua: str | None,
    opcua_allow_anonymous_read: bool,
    web: str | None,
    audit: str | None,
    no_audit: bool,
    allow_remote: bool,
    token: str | None,
    log_format: str,
    verbose: bool,
) -> None:
    """Own controller lines and serve them to many consumers at once (N1, API, metrics, ...).

    Each line is opened once; consumers share it through the faces. Faces bind to loopback
    unless --allow-remote (with a token). SIGTERM or Ctrl-C stops jogs and exits.

    \b
    Example:
      robostar serve --line cell1=/dev/ttyUSB0 --n1 cell1=127.0.0.1:9101 --api 127.0.0.1:8470
      robostar --port tcp://127.0.0.1:9101 status        # any N1 host program
      robostar --port serve://127.0.0.1:8470/cell1 status
      robostar serve --check serve.toml                  # validate, open nothing
      robostar serve --config serve.toml --metrics 127.0.0.1:9464
      robostar serve user add olga --role operator --users users.toml   # web and OPC UA users
      robostar serve --line cell1=sim:// --opcua 127.0.0.1:4840 --opcua-allow-anonymous-read
      robostar serve --line cell1=sim:// --modbus cell1=127.0.0.1:5020   # a PLC, Modbus TCP
      robostar serve modbus-map --format csv              # the register map for the PLC
    """
    if ctx.invoked_subcommand is not None:
        return  # `robostar serve user ...`: manage users, serve nothing
    if check_file is not None:
        config = load_config(check_file)
        _check_faces(config)
        for text in _describe(config):
            click.echo(text)
        click.echo(f"{check_file}: OK ({len(config.lines)} lines)")
        return
    if allow_remote and not token:
        raise UsageError("--allow-remote needs --token (or ROBOSTAR_SERVE_TOKEN)")
    faces = {"api": api, "metrics": metrics, "mqtt": mqtt, "opcua": opcua, "web": web}
    config = build_config(
        config_file, lines, n1, faces, allow_remote, token, audit, no_audit, modbus
    )
    if opcua_allow_anonymous_read:
        if "opcua" not in config.faces:
            raise UsageError("--opcua-allow-anonymous-read needs --opcua (or [opcua])")
        config.faces["opcua"]["allow_anonymous_read"] = True
    handler = logging.StreamHandler(sys.stderr)
    if log_format == "json":
        handler.setFormatter(_JsonLines())
    else:
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger("robostar")
    root.addHandler(handler)
    root.setLevel(logging.DEBUG if verbose else logging.INFO)
    for text in _describe(config):
        click.echo(text, err=True)
    if os.name != "posix":
        raise UsageError("robostar serve runs on POSIX systems (signal handling)")
    default = default_audit_path()
    if config.audit_path == str(default):
        default.parent.mkdir(parents=True, exist_ok=True)  # a path given must exist already
    asyncio.run(_run(config))


serve.add_command(user)
serve.add_command(modbus_map)
