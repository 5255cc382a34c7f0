"""Jogging from a browser: the axis moves only while the page keeps saying so.

The page sends ``{"type": "keepalive"}`` every 100 ms while a jog button is held. The server
turns that into the controller's own keepalive (BF, within its 500 ms) and stops the axis with
BG when the page falls silent for :data:`SILENCE` seconds, on release, when the page is hidden
or loses focus, and when the socket closes. A browser is no enabling device: the page says so.

Inching (``{"type": "inch", "step": 0.1, ...}``) moves one axis by exactly one step with one BD
per press, refused while the channel is moving (a jog of this page, a job, a move not yet in
position). ``{"type": "speed", "percent": 20}`` sets the channel's speed (CB, which the jog
follows: the N1 protocol has no jog speed of its own).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import time
from collections.abc import Callable
from typing import Any, Protocol

from robostar.commands.control import SetSpeed
from robostar.commands.motion import JogContinue, JogStart, JogStop, MoveBy
from robostar.commands.status import ReadPosition, ReadStatus
from robostar.errors import RobostarError
from robostar.serve.lease import Who
from robostar.serve.line import Line
from robostar.types import CoordSystem, JogDirection, MotionType, PositionKind

__all__ = ["INCH_STEPS", "KEEPALIVE_EVERY", "SILENCE", "JogPanel"]

log = logging.getLogger(__name__)

SILENCE = 0.3
"""Seconds without a keepalive from the page after which the axis is stopped."""
KEEPALIVE_EVERY = 0.2
"""Seconds between BFs while the page keeps the jog alive (the controller allows 0.5)."""
_TICK = 0.05
INCH_STEPS = (0.01, 0.1, 1.0)
"""The steps an inch may take: mm, or degrees on a turning axis."""


class _Socket(Protocol):
    async def receive_text(self) -> str: ...

    async def send_text(self, data: str) -> None: ...


class JogPanel:
    """One browser's jog panel on one line: at most one axis moving at a time."""

    def __init__(self, line: Line, who: Who, allowed: Callable[[], bool] | None = None) -> None:
        self.line = line
        self.who = who
        self.allowed = allowed
        """Asked at every message: may the page's user still jog (signed in, a role)? When no
        longer, the axis stops and the session ends."""
        self.channel: int | None = None
        self._last_heard = 0.0
        self._last_bf = 0.0
        self._watchdog: asyncio.Task[None] | None = None
        self._socket: _Socket | None = None
        self._jog: tuple[JogStart, tuple[float, ...] | None, float] | None = None
        """The jog running: its command, the joint angles and the time it started."""
        self._started_wall = 0.0
        """When the jog running started (``time.time()``), for its audit entry."""

    async def run(self, socket: _Socket) -> None:
        """Serve the page's messages until the socket closes."""
        self._socket = socket
        while True:
            message = _parse(await socket.receive_text())
            kind = message.get("type")
            if self.allowed is not None and not self.allowed():
                await self.stop("signed out, or no longer an operator")
                await self._tell({"type": "error", "error": "sign in again as an operator"})
                return
            if kind == "start":
                await self._start(message)
            elif kind == "keepalive":
                self._last_heard = time.monotonic()
            elif kind == "stop":
                await self.stop(str(message.get("reason", "released")))
            elif kind == "inch":
                await self._inch(message)
            elif kind == "speed":
                await self._speed(message)
            else:
                await self._tell({"type": "error", "error": f"unknown message {kind!r}"})

    async def _start(self, message: dict[str, Any]) -> None:
        await self.stop("a new jog")
        try:
            channel, axis = int(message["channel"]), int(message["axis"])
            direction = JogDirection.PLUS if message.get("direction") == "+" else JogDirection.MINUS
            motion = MotionType.LINEAR if message.get("motion") == "linear" else MotionType.JOINT
            command = JogStart(channel, axis, direction, motion)
            command.encode()  # refuse a bad axis or channel before the line
            if self.line.info is not None and not 1 <= axis <= self._axis_count(channel):
                raise ValueError(f"channel {channel} has axes 1-{self._axis_count(channel)}")
        except (KeyError, ValueError, TypeError, RobostarError) as exc:
            await self._tell({"type": "error", "error": f"bad jog request: {exc}"})
            return
        try:
            # audited here as one entry when it stops (the line records a failure itself)
            await self.line.execute(command, who=self.who, implicit_lease=True, face_audits=True)
        except RobostarError as exc:
            await self._tell({"type": "error", "error": str(exc)})
            return
        self._started_wall = time.time()
        self.channel = channel
        self._last_heard = self._last_bf = time.monotonic()
        self._jog = (command, self._angles(channel), self._last_heard)
        self._watchdog = asyncio.create_task(self._watch(channel))
        await self._tell({"type": "moving", "channel": channel, "axis": axis})

    async def _inch(self, message: dict[str, Any]) -> None:
        """One BD of one step on one axis, if nothing on the channel is moving."""
        try:
            channel, axis = int(message["channel"]), int(message["axis"])
            step = float(message["step"])
            if step not in INCH_STEPS:
                raise ValueError(f"a step is one of {', '.join(map(str, INCH_STEPS))}")
            linear = message.get("motion") == "linear"
            axes = self._axis_count(channel)
            if not 1 <= axis <= axes:
                raise ValueError(f"channel {channel} has axes 1-{axes}")
            sign = 1.0 if message.get("direction") == "+" else -1.0
            delta = tuple(sign * step if n == axis else 0.0 for n in range(1, axes + 1))
            command = MoveBy(
                channel,
                MotionType.LINEAR if linear else MotionType.JOINT,
                CoordSystem.XY if linear else CoordSystem.ANGLE,
                delta,
            )
            command.encode()
        except (KeyError, ValueError, TypeError, RobostarError) as exc:
            await self._tell({"type": "error", "error": f"bad inch request: {exc}"})
            return
        if self.channel is not None:
            await self._tell({"type": "error", "error": "release the jog first: the axis moves"})
            return
        try:
            statuses = await self.line.read(ReadStatus(), max_age=0)
            status = statuses[channel - 1]
            # in position is a servo-on state: with the servo off the controller refuses BD itself
            if status.running or (status.servo_on and not status.in_position):
                await self._tell(
                    {"type": "error", "error": f"channel {channel} is moving: wait until it stops"}
                )
                return
            await self.line.execute(command, who=self.who, implicit_lease=True)
        except RobostarError as exc:
            await self._tell({"type": "error", "error": str(exc)})
            return
        await self._tell({"type": "inched", "channel": channel, "axis": axis, "step": sign * step})

    async def _speed(self, message: dict[str, Any]) -> None:
        try:
            channel = int(message["channel"])
            percent = float(message["percent"])
            if not 0 < percent <= 100:
                raise ValueError("a speed is 1-100 %")
            command = SetSpeed(channel, round(percent * 10))
            command.encode()
            await self.line.execute(command, who=self.who, implicit_lease=True)
        except (KeyError, ValueError, TypeError, RobostarError) as exc:
            await self._tell({"type": "error", "error": f"speed: {exc}"})
            return
        await self._tell({"type": "speed", "channel": channel, "percent": percent})

    def _axis_count(self, channel: int) -> int:
        """The channel's axes (AD), else as many as its last joint position has."""
        info = self.line.info
        if info is not None:
            for entry in info.channels:
                if entry.channel == channel and entry.axes_in_use:
                    return len(entry.axes_in_use)
        sample = self.line.model.get(f"ch{channel}/angles")
        if sample is None:
            raise ValueError(f"channel {channel}: its axes are not known yet")
        return len(sample.value.axes)

    async def _watch(self, channel: int) -> None:
        """Keep the jog alive while the page does; stop it when the page falls silent."""
        while self.channel == channel:
            await asyncio.sleep(_TICK)
            now = time.monotonic()
            if now - self._last_heard > SILENCE:
                self._watchdog = None  # stop() must not cancel the task that calls it
                await self.stop("the page stopped sending keepalives")
                return
            if now - self._last_bf >= KEEPALIVE_EVERY:
                self._last_bf = now
                try:
                    await self.line.execute(JogContinue(channel), who=self.who)
                except RobostarError as exc:
                    log.warning("jog on %s: keepalive failed: %s", self.line.name, exc)

    async def stop(self, reason: str) -> None:
        """BG for the jogging channel (if one is jogging), and tell the page why."""
        channel, self.channel = self.channel, None
        watchdog, self._watchdog = self._watchdog, None
        if watchdog is not None:
            watchdog.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await watchdog
        if channel is None:
            return
        outcome = f"stopped: {reason}"
        try:
            await self.line.execute(JogStop(channel), who=self.who, face_audits=True)
        except RobostarError as exc:  # the line has recorded the failed BG too
            log.warning("jog on %s: BG failed: %s", self.line.name, exc)
            outcome = f"stop failed ({reason}): {exc}"
        await self._tell({"type": "stopped", "channel": channel, "reason": reason})
        await self._summarize(channel, outcome)

    def _angles(self, channel: int) -> tuple[float, ...] | None:
        sample = self.line.model.get(f"ch{channel}/angles")
        return None if sample is None else tuple(sample.value.axes)

    async def _summarize(self, channel: int, outcome: str) -> None:
        """The jog's one audit entry (its JogStart and JogStop that went through are not
        recorded apart): which axis, when it started, how long, how far, why it stopped."""
        if self._jog is None:
            return
        command, before, started = self._jog
        self._jog = None
        with contextlib.suppress(RobostarError):  # after BG: where the axis came to rest
            await self.line.read(ReadPosition(channel, PositionKind.ANGLE), max_age=0)
        after = self._angles(channel)
        sign = "+" if command.direction == JogDirection.PLUS else "-"
        what = (
            f"jog channel {channel} axis {command.axis} {sign} ({command.motion.name.lower()}):"
            f" started {_clock(self._started_wall)}, {time.monotonic() - started:.1f} s"
        )
        if before is not None and after is not None and len(before) >= command.axis:
            moved = after[command.axis - 1] - before[command.axis - 1]
            what += (
                f", axis {command.axis} moved {moved:+.3f} (from {before[command.axis - 1]:.3f}"
                f" to {after[command.axis - 1]:.3f}, degrees or mm)"
            )
        self.line.record(what, self.who, outcome)

    async def _tell(self, message: dict[str, Any]) -> None:
        if self._socket is None:
            return
        with contextlib.suppress(Exception):  # the page may be gone; the jog is stopped anyway
            await self._socket.send_text(json.dumps(message))


def _clock(when: float) -> str:
    """A wall-clock instant to the millisecond, as the audit entry shows a jog's start."""
    return time.strftime("%H:%M:%S", time.gmtime(when)) + f".{int(when % 1 * 1000):03d} UTC"


def _parse(text: str) -> dict[str, Any]:
    try:
        value = json.loads(text)
    except ValueError:
        return {}
    return value if isinstance(value, dict) else {}
