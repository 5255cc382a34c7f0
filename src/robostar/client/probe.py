"""Finding a controller's baud rate: send AA at each usual rate and see which one answers."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robostar.client import args
from robostar.client.sync import Client
from robostar.errors import PortError, RobostarError, UsageError
from robostar.transport.url import Kind, parse_url
from robostar.types import ChannelStatus

__all__ = ["BAUD_RATES", "ProbeAttempt", "ProbeResult", "probe"]

BAUD_RATES = (115200, 57600, 38400, 19200, 9600, 230400)
"""The N1's factory rate first, then the others its HOST port offers."""


@dataclass(frozen=True, slots=True)
class ProbeAttempt:
    """One rate tried: ``error`` is None when AA was answered."""

    baudrate: int | None
    error: str | None = None


@dataclass(frozen=True, slots=True)
class ProbeResult:
    """What :func:`probe` found: the answering rate (None for a non-serial URL, or when
    nothing answered), the status it read, and every attempt in order."""

    port: str
    found: bool
    baudrate: int | None
    status: tuple[ChannelStatus, ChannelStatus, ChannelStatus] | None
    attempts: tuple[ProbeAttempt, ...]

    def __str__(self) -> str:
        if not self.found:
            return f"{self.port}: no answer at " + ", ".join(str(a.baudrate) for a in self.attempts)
        rate = f" at {self.baudrate} baud" if self.baudrate else ""
        return f"{self.port}: controller answered{rate}"


def probe(
    port: str,
    *,
    baudrates: tuple[int, ...] = BAUD_RATES,
    timeout: float = 0.5,
    **options: Any,
) -> ProbeResult:
    """Send AA (read status) at each rate in ``baudrates`` until one is answered.

    A port that cannot be opened raises PortError at once (no rate would help). For a
    ``tcp://`` or ``sim://`` URL there is no rate to try: AA is sent once.
    """
    args.positive(timeout, "timeout")
    serial = parse_url(port).kind in (Kind.SERIAL, Kind.PYSERIAL_URL)
    rates: tuple[int | None, ...] = tuple(baudrates) if serial else (None,)
    if not rates:
        raise UsageError("baudrates: give at least one rate")
    attempts = []
    for rate in rates:
        extra: dict[str, Any] = {"baudrate": rate} if rate is not None else {}
        client = Client(port, timeout=timeout, retries=0, **extra, **options)
        try:
            status = client.status()
        except PortError:
            raise
        except RobostarError as exc:
            attempts.append(ProbeAttempt(rate, str(exc)))
            continue
        finally:
            client.close()
        attempts.append(ProbeAttempt(rate))
        return ProbeResult(port, True, rate, status, tuple(attempts))
    return ProbeResult(port, False, None, None, tuple(attempts))
