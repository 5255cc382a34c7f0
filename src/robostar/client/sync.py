"""The blocking client: :class:`Client`. Safe to share between threads."""

from __future__ import annotations

import contextlib
import time
import weakref
from collections.abc import Callable
from types import TracebackType
from typing import Any, Self, TypeVar

from robostar.client._sync_face import SyncOperations
from robostar.client.core import DRAIN_READS, ClientBase, Settings, check_keepalive
from robostar.client.driver import NOT_DECODED, FollowUp, decoded_at_once, follow_up
from robostar.client.exchange import Exchange, Progress
from robostar.client.jog import Jog, jog_start
from robostar.client.locks import PriorityLock
from robostar.client.plan import Blocking, Call, Effect, Plan, run_plan
from robostar.client.trace import TraceTarget
from robostar.commands.base import Command
from robostar.errors import PortError, RobostarError, UsageError
from robostar.transport import Transport, transport_for_url
from robostar.types import JogDirection, MotionType

__all__ = ["Client"]

R = TypeVar("R")


class Client(SyncOperations, ClientBase):
    """A connection to one N1 controller, with every protocol command as a method.

    ``port`` is a device (``"/dev/ttyUSB0"``, ``"COM3"``), a URL (``"tcp://host:20000"``,
    ``"sim://"``, ``"serial:///dev/ttyUSB0?baudrate=57600"``, a pyserial URL) or a
    :class:`~robostar.transport.Transport`. The line is opened at once (PortError if it cannot
    be). One exchange runs at a time; threads take turns, jog keepalives first.

    Options: ``timeout`` reply timeout (2 s); ``retries`` resends of a read-only command after
    a lost answer (1; state-changing commands are never resent); ``trace`` a path or callable
    for the wire trace; ``reconnect`` reopen a lost line on the next call; ``poll_interval``
    status reads while waiting (0.1 s); ``keepalive`` jog BF interval (0.2 s, under 0.5 s);
    ``controller_timeout`` the controller's own resend timeout (default: ``timeout``; the
    manual's 2 s on both sides), which tells its resends from a slow controller's answers;
    other keyword options go to the transport (``baudrate=57600``).
    """

    transport: Transport

    def __init__(
        self,
        port: str | Transport,
        *,
        timeout: float = 2.0,
        retries: int = 1,
        trace: TraceTarget | None = None,
        reconnect: bool = False,
        poll_interval: float = 0.1,
        keepalive: float = 0.2,
        controller_timeout: float | None = None,
        **transport_options: Any,
    ) -> None:
        settings = Settings(
            timeout, retries, poll_interval, keepalive, reconnect, controller_timeout
        )
        if isinstance(port, Transport):
            if transport_options:
                raise UsageError("transport options go with a URL, not with a Transport")
            self.transport = port
        else:
            self.transport = transport_for_url(port, **transport_options)
        self._setup(settings, trace)
        self._lock = PriorityLock()
        self._jogs: weakref.WeakSet[Jog] = weakref.WeakSet()
        try:
            self._open()
        except BaseException:
            self._close_trace()
            raise

    # -- life cycle ------------------------------------------------------------------------
    def _open(self) -> None:
        if not self.transport.is_open:
            self.transport.open()
        self._opened = True
        self._link = self._new_link()

    def _ensure_open(self) -> None:
        if not self.transport.is_open:
            self._check_may_open()
            self._open()

    def close(self) -> None:
        """Stop running jogs (BG), close the line and the trace file; later calls raise
        PortError."""
        if self._closed:
            return
        for jog in list(self._jogs):
            with contextlib.suppress(RobostarError):
                jog.stop()
        with self._lock.hold(urgent=True):
            self._closed = True
            self.transport.close()
            self._close_trace()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- running plans ---------------------------------------------------------------------
    def _run(self, plan: Plan[R]) -> R:
        return run_plan(plan, self._perform)

    def _perform(self, effect: Effect) -> object:
        if isinstance(effect, Call):
            return self._call(effect.command, effect.progress)
        if isinstance(effect, Blocking):
            return effect.function()
        time.sleep(effect.seconds)
        return None

    def _call(
        self, command: Command[R], progress: Progress | None = None, *, urgent: bool = False
    ) -> R:
        """Run one command (its retries and KD follow-up included) while holding the line."""
        lock = self._lock
        lock.acquire(urgent)
        try:
            if not self.transport.is_open:
                self._ensure_open()
            exchange = self._exchange(command, progress)
            # the usual case, a clean answer that decodes, needs none of the rules
            result = decoded_at_once(command, exchange)
            if result is not NOT_DECODED:
                return result
            return run_plan(follow_up(command, exchange, self._policy, progress), self._follow)
        finally:
            lock.release()

    def _follow(self, step: FollowUp) -> Exchange:
        """Run one exchange the rules asked for (driver.follow_up)."""
        if step.retry:
            self._link.retry_next()
        return self._exchange(step.command, step.progress)

    # -- the line -------------------------------------------------------------------------
    def _exchange(self, command: Command[Any], progress: Progress | None) -> Exchange:
        """One exchange, as one loop: stray input first, the request, then answers until the
        link says the exchange is over (see core.ClientBase for the rules it shares)."""
        transport = self.transport
        traced = self._trace is not None
        link = self._link
        exchange = Exchange(link, command, progress)
        written = False
        clock = time.monotonic
        try:
            now = clock()
            stray = transport.read(0.0)  # the drain's first read
            if stray:
                self._drain(stray)
                now = clock()
            exchange.start(now)
            while True:
                # exchange.output(), without the call (the first time: anything the idle link
                # had to say, then the request, in that order)
                out = link.data_to_send()
                if out:
                    # the request is out once an exchange is open (RESYNC's RSTs are not it)
                    written = written or link.busy or exchange.done
                    if traced:
                        self._traced_sent(out)
                    transport.write(out)
                if exchange.done:
                    return exchange
                deadline = link.next_deadline()
                if deadline is None:
                    deadline = exchange.deadline()  # raises: the link must be timing a wait
                wait = deadline - clock()
                data = transport.read(wait if wait > 0.0 else 0.0)
                now = clock()
                if data:
                    if traced:
                        self._traced_received(data)
                    exchange.receive(data, now)
                else:
                    exchange.tick(now)
        except PortError as exc:
            raise self._line_lost(command, exc, written) from exc
        except BaseException:
            # Ctrl-C, a callback's error: end the exchange with RST.
            out = self._abort_output(exchange)
            if out:
                try:
                    transport.write(out)
                except PortError:
                    self._link = self._new_link()
            raise

    def _drain(self, first: bytes | None = None) -> None:
        """Hand stray input to the idle link before a request (it ACKs a resent answer).
        ``first``: the first read(0)'s bytes when the caller has read them (None: not read)."""
        for _ in range(DRAIN_READS):
            if first is None:
                data = self.transport.read(0.0)
            else:
                data, first = first, None
            if not data:
                break
            self._stray_input(data)
        out = self._link_output()
        if out:
            self.transport.write(out)

    # -- jogging ---------------------------------------------------------------------------
    def jog(
        self,
        channel: int,
        axis: int,
        direction: str | int | JogDirection,
        *,
        motion: str | MotionType = "joint",
        interval: float | None = None,
        held_until: Callable[[], float] | None = None,
    ) -> Jog:
        """BE, BF every ``interval`` s (the client's ``keepalive``), BG at the end.

        Use as ``with client.jog(1, axis=1, direction="+"): ...``. ``direction`` is "+"/"-"
        (or 1/-1); ``motion`` "joint" or "linear". ``held_until``: a dead-man's switch, a
        callable giving the ``time.monotonic()`` until which the jog is wanted; once it has
        passed, the keepalive sends BG by itself (see :class:`~robostar.client.jog.Jog`).
        """
        start = jog_start(channel, axis, direction, motion)
        every = (
            self.settings.keepalive if interval is None else check_keepalive(interval, "interval")
        )
        jog = Jog(self._urgent_call, start, every, held_until=held_until)
        self._jogs.add(jog)
        return jog

    def _urgent_call(self, command: Command[None]) -> None:
        self._call(command, urgent=True)
