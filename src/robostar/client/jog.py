"""Jogging: BE, then BF every ``interval`` (under 500 ms), and BG however the jog ends.

A :class:`Jog` (blocking client) keeps the jog alive from a background thread, an
:class:`AsyncJog` from a task. Keepalives go ahead of other calls on the client (see
:mod:`robostar.client.locks`). BG is sent when the ``with`` block ends, normally or by an
exception (Ctrl-C included); at interpreter exit for jogs still running; and on SIGTERM the
keepalives stop at once (so the controller stops the robot within 500 ms) before the previous
handler runs - by default Python's exit, as :class:`SystemExit`, so ``with`` blocks and exit
handlers still send BG.

A jog may also carry a dead-man's switch, ``held_until``: a callable giving the
:func:`time.monotonic` time until which the jog is wanted (a jog pad's key-hold deadline). The
keepalive itself stops sending BF once that time passes, and sends BG, so the robot stops even
when the code that should end the jog is stuck (a screen write blocked by Ctrl-S or a backed-up
SSH session).
"""

from __future__ import annotations

import asyncio
import atexit
import contextlib
import math
import signal
import threading
import time
from collections.abc import Awaitable, Callable
from types import FrameType, TracebackType
from typing import Protocol

from robostar.client import args
from robostar.commands.base import Command
from robostar.commands.motion import JogContinue, JogStart, JogStop
from robostar.errors import (
    JogInterruptedError,
    LineError,
    OutcomeUnknownError,
    RobostarError,
    UsageError,
)
from robostar.types import JogDirection, MotionType

__all__ = ["AsyncJog", "Jog", "jog_start"]


class _Halt(Protocol):
    def halt(self) -> None: ...


class _Registry:
    """Jogs running in this process, for the exit and SIGTERM handlers."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._jogs: set[_Halt] = set()
        self._at_exit_registered = False
        self._sigterm_handled = False

    def add(self, jog: _Halt) -> None:
        with self._lock:
            self._jogs.add(jog)
            if not self._at_exit_registered:
                self._at_exit_registered = True
                atexit.register(self._at_exit)
            # Only the main thread may set a signal handler: a jog started elsewhere leaves it
            # to the next one started there (exit handlers still cover a clean exit).
            if not self._sigterm_handled and threading.current_thread() is threading.main_thread():
                self._sigterm_handled = True
                self._install_sigterm()

    def discard(self, jog: _Halt) -> None:
        with self._lock:
            self._jogs.discard(jog)

    def running(self) -> list[_Halt]:
        with self._lock:
            return list(self._jogs)

    def _at_exit(self) -> None:
        for jog in self.running():
            if isinstance(jog, Jog):
                with contextlib.suppress(Exception):
                    jog.stop()

    def _install_sigterm(self) -> None:
        previous = signal.getsignal(signal.SIGTERM)
        if previous == signal.SIG_IGN:
            return

        def on_sigterm(signum: int, frame: FrameType | None) -> None:
            jogs = self.running()
            for jog in jogs:
                jog.halt()
            if callable(previous):
                previous(signum, frame)
            elif jogs:
                # Exit as the default would, but by unwinding: ``with`` blocks send BG.
                raise SystemExit(128 + signum)
            else:
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                signal.raise_signal(signal.SIGTERM)

        signal.signal(signal.SIGTERM, on_sigterm)


_registry = _Registry()


class _JogBase:
    """What both jogs keep, and how a ``with`` block around one ends."""

    def __init__(
        self, start: JogStart, interval: float, held_until: Callable[[], float] | None = None
    ) -> None:
        self.command = start
        self.interval = interval
        self.held_until = held_until
        """The dead-man's switch: a callable giving the monotonic time until which the jog is
        wanted, read before every keepalive; None keeps the jog alive until it is stopped."""
        self.error: BaseException | None = None
        """Why the keepalive failed, if it did (the controller has stopped the jog)."""
        self.expired = False
        """True once ``held_until`` passed: the keepalives stopped and BG was tried."""
        self._running = False

    @property
    def running(self) -> bool:
        return self._running

    def _next_due(self, due: float) -> float:
        # Fixed rate from the schedule; after a late keepalive, the next goes at once.
        return max(due + self.interval, time.monotonic())

    def _deadline(self) -> float:
        """The hold deadline (infinite without a switch); a switch that fails reads as let
        go, since a jog must never outlive the code that holds it."""
        if self.held_until is None:
            return math.inf
        try:
            return float(self.held_until())
        except Exception:
            return -math.inf

    def _wake(self, due: float) -> float:
        """Seconds until the next keepalive is due, or sooner: until the hold deadline, so
        that BG goes out when it passes rather than up to an interval later."""
        return max(min(due, self._deadline()) - time.monotonic(), 0.0)

    def _released(self) -> bool:
        """The dead-man's switch let go: BF must stop (the caller no longer wants the jog)."""
        if time.monotonic() < self._deadline():  # False for a NaN too: it lets go
            return False
        self.expired = True
        return True

    def _ended(self, exc: BaseException | None, stop_error: Exception | None) -> None:
        """After BG at the end of a ``with`` block: raise what the caller must hear of.

        A failed keepalive, or a line lost by the time of BG, is a JogInterruptedError that
        carries BG's outcome, never a bare PortError: the caller learns that the jog stopped
        early and whether the stop itself reached the controller."""
        channel = self.command.channel
        if stop_error is None:
            bg = "BG was sent after it"
        else:
            bg = f"BG failed too ({stop_error}); the controller's watchdog stops the jog"
        if exc is None and self.error is not None:
            raise JogInterruptedError(
                f"channel {channel}: a jog keepalive (BF) failed, so the controller stopped "
                f"the jog: {self.error}; {bg}",
                stop_error=stop_error,
            ) from self.error
        if stop_error is None:
            return
        if exc is not None:
            exc.add_note(f"robostar: the jog stop (BG) failed too: {stop_error}")
            return
        if isinstance(stop_error, LineError):
            raise JogInterruptedError(
                f"channel {channel}: the line failed by the end of the jog: {bg}",
                stop_error=stop_error,
            ) from stop_error
        raise stop_error


class Jog(_JogBase):
    """A running jog on a blocking client; use it in a ``with`` block (or start()/stop()).

    ``held_until``, when given, is the dead-man's switch: a callable returning the
    :func:`time.monotonic` time until which the jog is wanted. The keepalive thread reads it
    before every BF; once that time has passed it sends no more BF, sends BG (a failure of that
    BG is ignored: without BF the controller stops the jog within 500 ms anyway), sets
    :attr:`expired` and ends. A caller that keeps the jog going extends the time it returns; one
    that hangs stops extending it, and the robot stops. None (the default) keeps the jog alive
    until it is stopped, as before.
    """

    def __init__(
        self,
        call: Callable[[Command[None]], None],
        start: JogStart,
        interval: float,
        *,
        held_until: Callable[[], float] | None = None,
    ) -> None:
        super().__init__(start, interval, held_until)
        self._call = call
        self._halted = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Send BE and start the keepalives."""
        if self._running:
            return
        try:
            self._call(self.command)
        except OutcomeUnknownError:
            # BE may have started the axis, and no keepalive will follow: stop it now rather
            # than leave it to the controller's 500 ms watchdog (a stop is safe either way).
            with contextlib.suppress(RobostarError):
                self._call(JogStop(self.command.channel))
            raise
        self._running = True
        _registry.add(self)
        self._thread = threading.Thread(
            target=self._keepalive, name=f"robostar jog ch{self.command.channel}", daemon=True
        )
        self._thread.start()

    def halt(self) -> None:
        """Stop the keepalives without sending anything (the robot stops within 500 ms)."""
        self._halted.set()

    def stop(self) -> None:
        """Stop the keepalives and send BG."""
        if not self._running:
            return
        self.halt()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join()
        self._running = False
        _registry.discard(self)
        self._call(JogStop(self.command.channel))

    def _keepalive(self) -> None:
        keep = JogContinue(self.command.channel)
        due = time.monotonic() + self.interval
        while not self._halted.wait(self._wake(due)):
            if self._released():
                # Nobody is holding the jog: stop it here, not in the caller, which may hang.
                with contextlib.suppress(Exception):
                    self._call(JogStop(self.command.channel))
                return
            if time.monotonic() < due:
                continue  # woken for the deadline, which has been extended meanwhile
            try:
                self._call(keep)
            except BaseException as exc:  # reported by __exit__
                self.error = exc
                return
            due = self._next_due(due)

    def __enter__(self) -> Jog:
        self.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        try:
            self.stop()
        except Exception as stop_error:
            self._ended(exc, stop_error)
        else:
            self._ended(exc, None)


class AsyncJog(_JogBase):
    """A running jog on an asyncio client; use it in an ``async with`` block.

    ``held_until`` is the same dead-man's switch as :class:`Jog`'s (read by the keepalive
    task); None, the default, keeps the jog alive until it is stopped.
    """

    def __init__(
        self,
        call: Callable[[Command[None]], Awaitable[None]],
        start: JogStart,
        interval: float,
        *,
        held_until: Callable[[], float] | None = None,
    ) -> None:
        super().__init__(start, interval, held_until)
        self._call = call
        self._halted = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        """Send BE and start the keepalive task."""
        if self._running:
            return
        try:
            await self._call(self.command)
        except OutcomeUnknownError:
            # as Jog.start: BE may have started the axis, and no keepalive will follow
            with contextlib.suppress(RobostarError):
                await self._call(JogStop(self.command.channel))
            raise
        self._running = True
        _registry.add(self)
        self._task = asyncio.create_task(self._keepalive())

    def halt(self) -> None:
        """Stop the keepalives without sending anything (the robot stops within 500 ms)."""
        self._halted.set()

    async def stop(self) -> None:
        """Stop the keepalives and send BG."""
        if not self._running:
            return
        self.halt()
        if self._task is not None:
            await self._task
        self._running = False
        _registry.discard(self)
        await self._call(JogStop(self.command.channel))

    async def _keepalive(self) -> None:
        keep = JogContinue(self.command.channel)
        due = time.monotonic() + self.interval
        while True:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self._wake(due)):
                    await self._halted.wait()
            if self._halted.is_set():
                return
            if self._released():
                with contextlib.suppress(Exception):
                    await self._call(JogStop(self.command.channel))
                return
            if time.monotonic() < due:
                continue  # woken for the deadline, which has been extended meanwhile
            try:
                await self._call(keep)
            except Exception as exc:  # reported by __aexit__
                self.error = exc
                return
            due = self._next_due(due)

    async def __aenter__(self) -> AsyncJog:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        try:
            await self.stop()
        except Exception as stop_error:
            self._ended(exc, stop_error)
        else:
            self._ended(exc, None)


def jog_start(
    channel: int, axis: int, direction: str | int | JogDirection, motion: str | MotionType
) -> JogStart:
    """The BE request of a jog, every argument checked."""
    kind = args.motion_type(motion)
    if kind not in (MotionType.JOINT, MotionType.LINEAR):
        raise UsageError(f"motion: a jog is 'joint' or 'linear', not {motion!r}")
    start = JogStart(args.channel(channel), axis, args.jog_direction(direction), kind)
    start.encode()  # the axis is checked here, before the jog object exists
    return start
