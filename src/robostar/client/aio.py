"""The asyncio client: :class:`AsyncClient`. Safe to share between tasks of one event loop."""

from __future__ import annotations

import asyncio
import contextlib
import time
import weakref
from collections.abc import Callable
from types import TracebackType
from typing import Any, Self, TypeVar

from robostar.client._async_face import AsyncOperations
from robostar.client.core import DRAIN_READS, ClientBase, Settings, check_keepalive
from robostar.client.driver import (
    NOT_DECODED,
    FollowUp,
    decoded_at_once,
    follow_up,
    note_cancelled,
)
from robostar.client.exchange import Exchange, Progress
from robostar.client.jog import AsyncJog, jog_start
from robostar.client.locks import AsyncPriorityLock
from robostar.client.plan import Blocking, Call, Effect, Plan, run_blocking, run_plan_async
from robostar.client.trace import TraceTarget
from robostar.commands.base import Command
from robostar.errors import PortError, RobostarError, UsageError
from robostar.transport import AsyncTransport, async_transport_for_url
from robostar.types import JogDirection, MotionType

__all__ = ["AsyncClient"]

R = TypeVar("R")


class AsyncClient(AsyncOperations, ClientBase):
    """The asyncio twin of :class:`~robostar.client.sync.Client`: the same methods, awaited.

    The line opens on ``await client.connect()``, on ``async with``, or on the first call.
    ``port`` and the options are those of the blocking client, or an
    :class:`~robostar.transport.AsyncTransport`.
    """

    transport: AsyncTransport

    def __init__(
        self,
        port: str | AsyncTransport,
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
        if isinstance(port, AsyncTransport):
            if transport_options:
                raise UsageError("transport options go with a URL, not with a Transport")
            self.transport = port
        else:
            self.transport = async_transport_for_url(port, **transport_options)
        self._setup(settings, trace)
        self._lock = AsyncPriorityLock()
        self._jogs: weakref.WeakSet[AsyncJog] = weakref.WeakSet()

    # -- life cycle ------------------------------------------------------------------------
    async def _open(self) -> None:
        if not self.transport.is_open:
            await self.transport.open()
        self._opened = True
        self._link = self._new_link()

    async def connect(self) -> None:
        """Open the line now (PortError if it cannot be opened)."""
        async with self._lock.hold():
            await self._ensure_open()

    async def _ensure_open(self) -> None:
        if not self.transport.is_open:
            self._check_may_open()
            await self._open()

    async def close(self) -> None:
        """Stop running jogs (BG), close the line and the trace file."""
        if self._closed:
            return
        for jog in list(self._jogs):
            with contextlib.suppress(RobostarError):
                await jog.stop()
        async with self._lock.hold(urgent=True):
            self._closed = True
            await self.transport.close()
            self._close_trace()

    async def __aenter__(self) -> Self:
        await self.connect()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    # -- running plans ---------------------------------------------------------------------
    async def _run(self, plan: Plan[R]) -> R:
        return await run_plan_async(plan, self._perform)

    async def _perform(self, effect: Effect) -> object:
        if isinstance(effect, Call):
            return await self._call(effect.command, effect.progress)
        if isinstance(effect, Blocking):
            return await run_blocking(effect)  # in a worker thread: the loop runs on
        await asyncio.sleep(effect.seconds)
        return None

    async def _call(
        self, command: Command[R], progress: Progress | None = None, *, urgent: bool = False
    ) -> R:
        lock = self._lock
        if not lock.try_acquire():
            await lock.acquire(urgent=urgent)
        try:
            if not self.transport.is_open:
                await self._ensure_open()
            exchange = await self._exchange(command, progress)
            # the usual case, a clean answer that decodes, needs none of the rules
            result = decoded_at_once(command, exchange)
            if result is not NOT_DECODED:
                return result
            return await run_plan_async(
                follow_up(command, exchange, self._policy, progress), self._follow
            )
        finally:
            lock.release()

    async def _follow(self, step: FollowUp) -> Exchange:
        """Run one exchange the rules asked for (driver.follow_up)."""
        if step.retry:
            self._link.retry_next()
        return await self._exchange(step.command, step.progress)

    # -- the line -------------------------------------------------------------------------
    async def _exchange(self, command: Command[Any], progress: Progress | None) -> Exchange:
        """One exchange, as one loop (the asyncio twin of Client._exchange)."""
        transport = self.transport
        traced = self._trace is not None
        link = self._link
        exchange = Exchange(link, command, progress)
        written = False
        clock = time.monotonic
        # A clean single answer is ACKed where it lands, a loop turn before this task resumes
        # (AsyncTransport.read_answering); traced or with progress, every byte comes here.
        answer = None if traced or progress is not None else exchange.answer_at_once
        try:
            stray = transport.read_nowait()  # the drain's first read(0), without awaiting
            if stray != b"":
                await self._drain(stray)
            exchange.start(clock())
            while True:
                # exchange.output(), without the call (the first time: anything the idle link
                # had to say, then the request, in that order)
                out = link.data_to_send()
                if out:
                    # the request is out once an exchange is open (RESYNC's RSTs are not it)
                    written = written or link.busy or exchange.done
                    if traced:
                        self._traced_sent(out)
                    pending = transport.write_nowait(out)  # await transport.write(out)
                    if pending is not None:
                        await pending
                if exchange.done:
                    return exchange
                deadline = link.next_deadline()
                if deadline is None:
                    deadline = exchange.deadline()  # raises: the link must be timing a wait
                if answer is None:
                    data = await transport.read(max(deadline - clock(), 0.0))
                else:
                    data = await transport.read_answering(max(deadline - clock(), 0.0), answer)
                    if exchange.done:  # taken, and ACKed (nothing else to send), by answer_at_once
                        return exchange
                if data:
                    if traced:
                        self._traced_received(data)
                    exchange.receive(data, clock())
                else:
                    exchange.tick(clock())
        except PortError as exc:
            raise self._line_lost(command, exc, written) from exc
        except BaseException as exc:
            # A cancelled task, Ctrl-C, a callback's error: end the exchange with RST.
            answered = exchange.done and exchange.answer() is not None
            out = self._abort_output(exchange)
            if isinstance(exc, asyncio.CancelledError):  # it propagates, with a note
                note_cancelled(exc, command, written, answered=answered)
            if out:
                try:
                    await transport.write(out)
                except PortError:
                    self._link = self._new_link()
            raise

    async def _drain(self, first: bytes | None = None) -> None:
        """Hand stray input to the idle link before a request (it ACKs a resent answer).
        ``first``: the first read(0)'s bytes when the caller has read them (None: not read)."""
        for _ in range(DRAIN_READS):
            if first is None:
                data = await self.transport.read(0.0)
            else:
                data, first = first, None
            if not data:
                break
            self._stray_input(data)
        out = self._link_output()
        if out:
            await self.transport.write(out)

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
    ) -> AsyncJog:
        """BE, BF every ``interval`` s from a task, BG at the end.

        Use as ``async with client.jog(1, axis=1, direction="+"): ...``. ``held_until``: the
        dead-man's switch, as :meth:`Client.jog <robostar.Client.jog>`'s.
        """
        start = jog_start(channel, axis, direction, motion)
        every = (
            self.settings.keepalive if interval is None else check_keepalive(interval, "interval")
        )
        jog = AsyncJog(self._urgent_call, start, every, held_until=held_until)
        self._jogs.add(jog)
        return jog

    async def _urgent_call(self, command: Command[None]) -> None:
        await self._call(command, urgent=True)
