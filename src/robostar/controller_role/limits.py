"""How much one controller-role host serves: sessions at once, unread bytes, idle connections.

One set of limits for both hosts of N1 sessions (the N1 face's asyncio
:class:`~robostar.serve.faces.n1.host.AsyncHost` and the simulator's threaded
:class:`~robostar.sim.host.PeerHost`), so a limit is defined and checked in one place.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from robostar.errors import UsageError

__all__ = [
    "IDLE_TIMEOUT",
    "MAX_CLIENTS",
    "MAX_PENDING",
    "MAX_PENDING_PTY",
    "HostLimits",
    "check_limits",
]

MAX_PENDING = 1 << 20
"""A TCP client that leaves this many bytes unread is dropped, so it cannot hold the host's memory
or stall the controller."""
MAX_PENDING_PTY = 1 << 16
"""Bytes for a pseudo-terminal nobody reads are thrown away past this, as on an unplugged line."""
MAX_CLIENTS = 16
"""Sessions (TCP clients) one host serves at once, by default."""
IDLE_TIMEOUT = 600.0
"""Seconds a connection may send and receive nothing before it is closed, by default. The N1
protocol has no unsolicited messages, so a host program that watches a robot asks every fraction
of a second or few seconds; ten minutes of silence is a connection nobody uses any more (a script
that did not close it, a program left open on a desk PC). Generous, so that no working host
program is cut off, yet it gives the slot back within minutes rather than never."""


@dataclass(frozen=True, slots=True)
class HostLimits:
    """How many sessions a host serves at once, and how long a silent one keeps its slot
    (``idle_timeout`` None: forever, leaving dead peers to TCP keepalive)."""

    max_clients: int = MAX_CLIENTS
    idle_timeout: float | None = IDLE_TIMEOUT

    def __post_init__(self) -> None:
        check_limits(self.max_clients, self.idle_timeout)

    @classmethod
    def from_options(cls, options: Mapping[str, object], where: str = "n1") -> HostLimits:
        """``max_clients`` (1 or more) and ``idle_timeout`` (seconds; 0 never closes an idle
        connection) from a config table; UsageError naming ``where.key`` when wrong."""
        max_clients = options.get("max_clients", MAX_CLIENTS)
        idle = options.get("idle_timeout", IDLE_TIMEOUT)
        if isinstance(max_clients, bool) or not isinstance(max_clients, int) or max_clients < 1:
            raise UsageError(f"{where}.max_clients: {max_clients!r} is not a whole number >= 1")
        if (
            isinstance(idle, bool)
            or not isinstance(idle, int | float)
            or not math.isfinite(idle)
            or idle < 0
        ):
            raise UsageError(
                f"{where}.idle_timeout: {idle!r} is not a number of seconds (0: never)"
            )
        return cls(max_clients, float(idle) if idle > 0 else None)


def check_limits(max_clients: object, idle_timeout: object) -> None:
    if isinstance(max_clients, bool) or not isinstance(max_clients, int) or max_clients < 1:
        raise UsageError(f"max_clients: {max_clients!r} is not 1 or more")
    if idle_timeout is not None and (
        isinstance(idle_timeout, bool)
        or not isinstance(idle_timeout, int | float)
        or not math.isfinite(idle_timeout)
        or idle_timeout <= 0
    ):
        raise UsageError(f"idle_timeout: {idle_timeout!r} is not a number of seconds > 0 or None")
