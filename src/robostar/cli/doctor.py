"""``robostar doctor``: check a port step by step and say what is wrong and what to do."""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Any

import click
from rich.console import Group, RenderableType
from rich.text import Text

import robostar
from robostar.cli.failures import EXIT_LINE, explain
from robostar.cli.options import common_options
from robostar.cli.session import ConsoleSession, pass_session
from robostar.commands.status import ReadInfo, ReadStatus
from robostar.errors import PortError, RobostarError

__all__ = ["Check", "doctor"]


@dataclass(frozen=True, slots=True)
class Check:
    """One step of the check-up; ``ok`` None means it did not apply."""

    name: str
    ok: bool | None
    detail: str
    hint: str = ""


def _view(port: str, checks: list[Check]) -> RenderableType:
    lines: list[RenderableType] = [Text(f"Checking {port}", style="bold")]
    for check in checks:
        if check.ok is None:
            mark, style = "-", "dim"
        elif check.ok:
            mark, style = "✓", "green"
        else:
            mark, style = "✗", "bold red"
        lines.append(Text(f" {mark} {check.name}: ", style=style) + Text(check.detail))
        if check.hint:
            lines.append(Text(f"     {check.hint}", style="dim"))
    verdict = all(c.ok is not False for c in checks)
    lines.append(
        Text(
            "All good." if verdict else "Something is wrong: see above.",
            style="green" if verdict else "bold red",
        )
    )
    return Group(*lines)


def serial_ports() -> Check:
    """The serial ports this machine has (pyserial's list_ports), so a --port can be chosen."""
    from serial.tools import list_ports

    found = sorted(list_ports.comports(), key=lambda p: p.device)
    if not found:
        return Check("serial ports", None, "none found on this machine")
    names = "; ".join(
        f"{p.device} ({p.description})" if p.description and p.description != "n/a" else p.device
        for p in found
    )
    return Check("serial ports", True, names)


def _probe(port: str, timeout: float) -> tuple[Check, int | None]:
    """Which baud rate answers (serial ports only)."""
    from robostar.client import probe
    from robostar.transport.url import Kind, parse_url

    if parse_url(port).kind not in (Kind.SERIAL, Kind.PYSERIAL_URL):
        return Check("baud rate", None, "not a serial line"), None
    result = probe(port, timeout=timeout)
    if not result.found:
        tried = ", ".join(str(a.baudrate) for a in result.attempts)
        return (
            Check(
                "baud rate",
                False,
                f"no answer at {tried}",
                "Check the cable (a null-modem cable for RS-232C) and that the controller's "
                "HOST port is enabled.",
            ),
            None,
        )
    tried = ", ".join(str(a.baudrate) for a in result.attempts)
    detail = f"the controller answers at {result.baudrate} baud (tried {tried})"
    return Check("baud rate", True, detail), result.baudrate


def _round_trips(session: ConsoleSession, count: int) -> Check:
    times = []
    for _ in range(count):
        start = time.perf_counter()
        session.client.execute(ReadStatus())
        times.append((time.perf_counter() - start) * 1000)
    detail = (
        f"{count} x AA: min {min(times):.1f} ms, mean {statistics.fmean(times):.1f} ms, "
        f"max {max(times):.1f} ms"
    )
    return Check("round trip", True, detail)


@click.command()
@click.option(
    "--count",
    type=click.IntRange(1, 1000),
    default=10,
    show_default=True,
    help="AA exchanges for the round-trip time.",
)
@common_options()
@pass_session
def doctor(session: ConsoleSession, count: int) -> None:
    """Check the port: it opens, the controller answers AA, which baud rate answers,
    the round-trip time, and the controller's name and version.

    \b
    Example:
      robostar --port /dev/ttyUSB0 doctor
      robostar --port tcp://192.0.2.10:20000 --json doctor
    """
    ports = serial_ports()
    if session.port_label == "(no port)":
        session.out.result(
            {"port": None, "ok": False, "serial_ports": ports.detail},
            Text(f"Serial ports here: {ports.detail}."),
        )
    port = session.port
    timeout = session.settings.timeout or 0.5
    checks: list[Check] = [Check("robostar", None, f"version {robostar.__version__}"), ports]
    if session.dry_run:
        session.plan([ReadStatus(), ReadInfo()], note="Plus AA at each baud rate on a serial line.")
    failed: RobostarError | None = None
    stage = "baud rate"
    try:
        probe_check, baud = _probe(port, timeout)
        checks.append(probe_check)
        if baud is not None and "baudrate=" not in port:
            session.client_options(baudrate=baud)
        stage = "port"
        client = session.client
        checks.append(Check("port", True, "opens"))
        stage = "answers AA"
        client.execute(ReadStatus())
        checks.append(Check("answers AA", True, "the controller answers"))
        stage = "round trip"
        checks.append(_round_trips(session, count))
        stage = "controller"
        info = client.execute(ReadInfo())
        models = ", ".join(ch.model for ch in info.channels[: info.max_channels] if ch.model)
        checks.append(
            Check(
                "controller",
                True,
                f"{info.name}, version {info.version}, {info.max_channels} channel(s): {models}",
            )
        )
    except RobostarError as error:
        failed = error
        failure = explain(error, port)
        if isinstance(error, PortError):
            stage = "port"
        checks.append(Check(stage, False, failure.message, failure.hint))
    data: dict[str, Any] = {
        "port": port,
        "ok": failed is None,
        "checks": [
            {"name": c.name, "ok": c.ok, "detail": c.detail, "hint": c.hint or None} for c in checks
        ],
    }
    data["tried"] = [c.name for c in checks if c.ok is not None]
    session.out.result(data, lambda: _view(port, checks))
    if failed is not None:
        raise click.exceptions.Exit(explain(failed, port).exit_code or EXIT_LINE)
