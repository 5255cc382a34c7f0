"""The control lease of one controller: one holder at a time, named, expiring, visible to all."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from robostar.errors import RobostarError

__all__ = [
    "FACES",
    "Lease",
    "LeaseHeldError",
    "LeaseInfo",
    "LeaseMode",
    "LeaseState",
    "Who",
    "utc_clock",
]

FACES = frozenset(("n1", "api", "mqtt", "opcua", "web", "modbus", "cli"))

LeaseMode = Literal["once", "hold"]
"""How a state change takes a free lease: ``"once"`` for that command only (given back as it
ends: a click, one MQTT command), ``"hold"`` to keep it past the command (a host program's
sequence; it runs out after the lease's idle time unless renewed by the holder's commands)."""


@dataclass(frozen=True)
class Who:
    """A consumer: its name (a connection, a user, a client id) and the face it came through."""

    name: str
    face: str

    def __str__(self) -> str:
        return f"{self.name} ({self.face})"


@dataclass(frozen=True)
class LeaseInfo:
    """Who holds the lease, since when and until when (``time.time()`` values); ``once``: taken
    for one command only (a one-shot lease, given back as its command ends)."""

    who: Who
    since: float
    expires_at: float
    once: bool = False


@dataclass(frozen=True)
class LeaseState:
    """A line's control as faces show it, taken at one instant: free (``holder`` None), or
    held by ``holder`` (its name) through ``face`` since ``since`` until ``until`` (wall clock,
    ``time.time()``) = ``until_monotonic`` (``time.monotonic()``, for timers that must not jump
    with the clock), ``left`` seconds from the instant taken; ``once``: a one-shot lease."""

    line: str
    holder: str | None = None
    face: str | None = None
    since: float | None = None
    until: float | None = None
    until_monotonic: float | None = None
    left: float | None = None
    once: bool = False

    @property
    def free(self) -> bool:
        return self.holder is None

    def as_dict(self) -> dict[str, object]:
        """For a JSON answer or an event."""
        return {
            "line": self.line,
            "free": self.free,
            "holder": self.holder,
            "face": self.face,
            "since": self.since,
            "until": self.until,
            "left": self.left,
            "once": self.once,
        }


def utc_clock(info: LeaseInfo) -> str:
    """When ``info``'s lease runs out, as a wall clock a person compares with theirs."""
    return time.strftime("%H:%M:%S UTC", time.gmtime(info.expires_at))


class LeaseHeldError(RobostarError):
    """The caller does not hold the controller's lease: another consumer does (the message
    names the holder), or nobody does (``holder`` None: the caller must take it first)."""

    def __init__(self, line: str, holder: LeaseInfo | None) -> None:
        if holder is None:
            # a free lease: the same refusal (type, HTTP 409, N1 flag), but no holder to name
            # (it said "held by nobody (-)", as if someone called "nobody" held it)
            message = f"line {line}: nobody holds the control lease; take it first"
        else:
            left = max(0.0, holder.expires_at - time.time())
            message = (
                f"line {line}: control is held by {holder.who} until {utc_clock(holder)}"
                f" (in {left:.0f} s unless renewed)"
            )
        super().__init__(message)
        self.line = line
        self.holder = holder


class Lease:
    """One holder at a time; an expired lease is free. Callbacks hear of every loss of the lease."""

    def __init__(
        self, line: str, *, ttl: float = 30.0, clock: Callable[[], float] = time.time
    ) -> None:
        self.line = line
        self.ttl = ttl
        self._clock = clock
        self._info: LeaseInfo | None = None
        self.on_lost: list[Callable[[Who], None]] = []
        """Called with the old holder when a lease is released, expires or is taken over."""

    @property
    def holder(self) -> LeaseInfo | None:
        info = self._info
        if info is not None and info.expires_at <= self._clock():
            self._info = None
            self._lost(info.who)
            return None
        return info

    def state(self) -> LeaseState:
        """Who holds the lease now, and until when (both clocks)."""
        info = self.holder
        if info is None:
            return LeaseState(self.line)
        left = max(0.0, info.expires_at - self._clock())
        return LeaseState(
            self.line,
            info.who.name,
            info.who.face,
            info.since,
            info.expires_at,
            time.monotonic() + left,
            left,
            info.once,
        )

    def held_by(self, who: Who) -> bool:
        info = self.holder
        return info is not None and info.who == who

    def acquire(self, who: Who, ttl: float | None = None, *, once: bool = False) -> LeaseInfo:
        """Take the lease (or renew it if ``who`` holds it); LeaseHeldError if another does.

        ``once``: for one command (see :class:`~robostar.serve.lease_gate.LeaseGate`); a lease
        ``who`` already holds to keep stays kept, and an explicit take keeps a one-shot one."""
        info = self.holder
        now = self._clock()
        if info is not None and info.who != who:
            raise LeaseHeldError(self.line, info)
        since = info.since if info is not None else now
        once = once and (info is None or info.once)
        self._info = LeaseInfo(who, since, now + (self.ttl if ttl is None else ttl), once)
        return self._info

    def renew(self, who: Who, ttl: float | None = None) -> LeaseInfo:
        """Push the expiry forward (kept as it was taken: once or to hold); LeaseHeldError if
        ``who`` does not hold the lease."""
        info = self.holder
        if info is None or info.who != who:
            raise LeaseHeldError(self.line, info)
        return self.acquire(who, ttl, once=info.once)

    def release(self, who: Who) -> bool:
        """Give the lease up; False if ``who`` did not hold it."""
        info = self.holder
        if info is None or info.who != who:
            return False
        self._info = None
        self._lost(who)
        return True

    def _lost(self, who: Who) -> None:
        for callback in list(self.on_lost):
            callback(who)
