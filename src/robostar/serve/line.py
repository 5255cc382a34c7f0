"""One controller line: a worker owning its AsyncClient and the line's priority queue.

Every exchange on the line goes through one queue served by one worker, so consumers never
interleave on the wire (as mbusd serialises Modbus TCP clients onto one RTU line). Stops (CF, CD,
CI, BG) go first and cancel a transfer in progress; a jog keepalive (BF) goes next; then the
consumers' requests, writes and reads alike, first come first served, and last the poller's reads
(:mod:`robostar.serve.line_queue`).

The line's collaborators each have one job: :class:`~robostar.serve.reads.ReadFlights` coalesces
reads (linearizable: each answered by an exchange that began after it arrived),
:class:`~robostar.serve.poller.Poller` keeps the model fresh through them (the
:class:`~robostar.serve.model_keys.ModelFeed` puts their answers in, its status witness
confirming a resting arm's positions),
:class:`~robostar.serve.lease_gate.LeaseGate` checks the lease as a state change is queued and
again as it is sent, :class:`~robostar.serve.jog_guard.JogGuard` stops jogs nobody keeps alive.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import time
from collections.abc import Callable
from typing import Any, TypeVar, cast

from robostar.client.aio import AsyncClient
from robostar.commands.base import Command
from robostar.commands.files import UploadFile
from robostar.commands.motion import JogContinue, JogStop
from robostar.commands.status import ReadInfo
from robostar.errors import (
    OutcomeUnknownError,
    PortError,
    ReplyTimeoutError,
    RobostarError,
    UsageError,
)
from robostar.serve.audit import AuditLog
from robostar.serve.audit_words import describe
from robostar.serve.backoff import Backoff
from robostar.serve.config import LineConfig
from robostar.serve.jog_guard import JogGuard
from robostar.serve.lease import (
    Lease,
    LeaseHeldError,
    LeaseInfo,
    LeaseMode,
    LeaseState,
    Who,
    utc_clock,
)
from robostar.serve.lease_gate import LeaseGate, LeaseLostError
from robostar.serve.line_errors import (
    AbortedByStopError,
    LineBusyError,
    LineDownError,
    WithdrawnError,
)
from robostar.serve.line_health import LineHealth
from robostar.serve.line_queue import (
    PRI_KEEPALIVE,
    PRI_REQUEST,
    PRI_STOP,
    STOPS,
    TRANSFERS,
)
from robostar.serve.line_queue import Job as _Job
from robostar.serve.model import ControllerModel, Quality
from robostar.serve.model_keys import ModelFeed, changed_by, model_key
from robostar.serve.poller import Poller, stale_after
from robostar.serve.reads import ReadFlights
from robostar.types import ControllerInfo

__all__ = [
    "MAX_QUEUED_READS",
    "STOPS",
    "AbortedByStopError",
    "ExchangeObserver",
    "LeaseLostError",
    "Line",
    "LineBusyError",
    "LineDownError",
    "LineHealth",
    "WithdrawnError",
    "model_key",
    "stale_after",
]

R = TypeVar("R")
ExchangeObserver = Callable[[Command[Any], Any, Who | None], None]
"""Called after each completed exchange: (command, its result or the error it ended with, who
asked: None for the poller's and for reads shared by several readers)."""
log = logging.getLogger("robostar.serve")

MAX_QUEUED_READS = 256
"""Consumers' reads waiting for the line at once; past it a read is refused (LineBusyError)
instead of making every later request, and the poller, wait behind it."""
_MAX_TIMEOUTS = 3
"""Consecutive reply timeouts after which the line is taken for down and reopened."""
_RECONNECT = Backoff(initial=0.2, factor=2.0, cap=10.0)
"""The waits between attempts to reopen a lost line: 0.2 s doubling up to 10 s."""


def _describe(command: Command[Any]) -> str:
    return describe(command)  # in words (serve/audit_words.py)


class Line:
    """One named controller line; see the module docstring for the order of the queue."""

    def __init__(
        self,
        config: LineConfig,
        *,
        audit: AuditLog | None = None,
        lease_ttl: float = 30.0,
        client_factory: Callable[[LineConfig], AsyncClient] | None = None,
    ) -> None:
        self.name = config.name
        self.config = config
        self.model = ControllerModel(config.name)
        self.feed = ModelFeed(self.model, config.rest_interval)
        """Reads' answers into the model, and reads that accept an older value out of it."""
        self.lease = Lease(config.name, ttl=lease_ttl)
        self.health = LineHealth()
        self.audit = audit if audit is not None else AuditLog(None)
        self._client_factory = client_factory or _default_client
        self._client: AsyncClient | None = None
        self._queue: asyncio.PriorityQueue[_Job] = asyncio.PriorityQueue()
        self._seq = itertools.count()
        self._current: _Job | None = None
        self._current_task: asyncio.Task[Any] | None = None
        self._aborted_by: Command[Any] | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._up = asyncio.Event()
        self._first_attempt = asyncio.Event()
        self._stopping = False
        self._timeouts = 0
        self._reads_waiting = 0
        self.info: ControllerInfo | None = None
        self._observers: list[ExchangeObserver] = []
        self.reads = ReadFlights(self._enqueue_shared, self._answered)
        """The line's reads, coalesced: consumers' and the poller's alike."""
        self.poller = Poller(
            config,
            self.model,
            self.health,
            self.reads,
            up=self._up,
            check_open=self._check_open,
            channels=self.channels,
            recent=lambda command, age: self.feed.answer(command, age) is not None,
        )
        self.gate = LeaseGate(self.name, self.lease, config.shared)
        self.jogs = JogGuard(self._send_jog_stop, self.record, self._takes_requests)
        self.lease.on_lost.append(self.jogs.lease_lost)
        if config.max_age:
            log.warning(
                "line %s: max_age = %g in its config has no effect any more: reads are answered"
                " by the controller unless a request accepts an older value (the API's max_age,"
                " serve://...?max_age=, n1.max_age)",
                self.name,
                config.max_age,
            )

    # -- life cycle ------------------------------------------------------------------------
    async def start(self) -> None:
        """Start the worker and the poller; returns after the first attempt to open the line."""
        self._stopping = False
        worker = asyncio.create_task(self._worker(), name=f"line {self.name} worker")
        self._tasks = [
            worker,
            asyncio.create_task(self.poller.run(), name=f"line {self.name} poller"),
            asyncio.create_task(self.poller.watch_staleness(), name=f"line {self.name} staleness"),
        ]
        # Should the worker die before its first attempt, say so instead of waiting for ever.
        attempted = asyncio.create_task(self._first_attempt.wait())
        await asyncio.wait((attempted, worker), return_when=asyncio.FIRST_COMPLETED)
        if not attempted.done():
            attempted.cancel()
            error = worker.exception() if not worker.cancelled() else None
            raise LineDownError(f"line {self.name}: its worker stopped at start: {error!r}")

    async def stop(self) -> None:
        """Stop running jogs, fail what is still queued, close the line."""
        if self._up.is_set():
            for channel in list(self.jogs.jogs):
                with contextlib.suppress(RobostarError, asyncio.TimeoutError):
                    await asyncio.wait_for(
                        self._submit(JogStop(channel), PRI_STOP, None), self.config.timeout
                    )
        self._stopping = True
        self._fail_queued(LineDownError(f"line {self.name}: the server is stopping"))
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            try:
                await task
            except asyncio.CancelledError:
                pass
            except Exception:  # already reported where it surfaced; stopping must finish
                log.debug("line %s: %s had failed", self.name, task.get_name(), exc_info=True)
        self._tasks = []
        await self._close_client()
        self._set_down("stopped")

    @property
    def up(self) -> bool:
        return self._up.is_set()

    @property
    def queue_depth(self) -> int:
        return self._queue.qsize() + (1 if self._current is not None else 0)

    # -- the public calls ------------------------------------------------------------------
    async def execute(
        self,
        command: Command[R],
        *,
        who: Who,
        implicit_lease: bool = False,
        lease: LeaseMode | None = None,
        face_audits: bool = False,
    ) -> R:
        """Run ``command`` for ``who`` through the queue (state changes need the lease).

        ``who`` holding the lease renews it. Else a free lease is taken: ``lease="once"`` (or
        ``implicit_lease=True``, the faces' one-shot commands) for this command only, given
        back as it ends (a jog start keeps it until the jog stops); ``lease="hold"`` to keep it
        past the command (an N1 host program's sequence). Without either, a free lease is
        refused (LeaseHeldError: take it first), as is one another holds.

        ``face_audits``: the face records this command's success in an entry of its own (a web
        jog's start and stop as one summary); the line still records a refusal, an error or an
        unknown outcome, so nothing that may have reached the wire goes unrecorded."""
        if not command.CHANGES_STATE:
            return await self.read(command, who=who)
        if lease is None and implicit_lease:
            lease = "once"
        is_stop = isinstance(command, STOPS)
        once = False
        if not is_stop:
            try:
                self.audit.ready()  # nothing moves that the log cannot record (stops do)
                if self.gate.needs_lease(command):  # not a write the line shares
                    once = self.gate.admit(who, mode=lease)
            except RobostarError as exc:
                self.record(command, who, f"refused: {exc}")
                raise
        try:
            return await self._carry_out(command, who, is_stop, face_audits)
        finally:
            if once:
                self.gate.ended(who, jogging=self._jogging)
            elif is_stop:
                self.gate.settle(self._jogging)  # a stop may have ended a one-shot jog

    # -- control (the lease), for faces ------------------------------------------------------
    def control(self) -> LeaseState:
        """Who holds this line's control now and until when (a face shows it on every page)."""
        return self.lease.state()

    def take_control(self, who: Who, seconds: float | None = None) -> LeaseInfo:
        """``who`` takes control (a free lease, kept past its commands, for ``seconds`` or the
        lease's idle time, renewed by its writes), or renews it; audited. LeaseHeldError
        when another holds it. Faces check the role first (an operator, at least)."""
        what = "lease renew" if self.lease.held_by(who) else "lease take"
        try:
            info = self.lease.acquire(who, seconds)
        except LeaseHeldError as exc:
            self.record(what, who, f"refused: {exc}")
            raise
        self.record(what, who, f"ok: until {utc_clock(info)}")
        return info

    def release_control(self, who: Who) -> bool:
        """``who`` gives control back (only its holder can); audited. False if not held."""
        released = self.lease.release(who)
        self.record("lease release", who, "ok" if released else "not held: nothing released")
        return released

    def _jogging(self, who: Who) -> bool:
        return who in self.jogs.jogs.values()

    async def _carry_out(
        self, command: Command[R], who: Who, is_stop: bool, face_audits: bool = False
    ) -> R:
        """:meth:`execute`'s part past the lease: queue, wait, audit, follow jogs."""
        priority = PRI_STOP if is_stop else PRI_REQUEST
        if isinstance(command, JogContinue):
            priority = PRI_KEEPALIVE
        job: _Job | None = None
        try:
            self._check_open()
            job = self._enqueue_job(command, priority, who)
            result: R = await job.future
        except asyncio.CancelledError:
            # the requester went away (a face draining at stop, a cancelled task): that is no
            # error of the robot's, and a write on the wire may well have been carried out
            outcome = _cancelled_outcome(job)
            self.record(command, who, outcome)
            self.jogs.failed(command, who, outcome)
            raise
        except LeaseLostError as exc:
            self.record(command, who, f"refused: {exc}")
            raise
        except WithdrawnError as exc:
            self.record(command, who, f"cancelled, not sent: {exc}")
            raise
        except BaseException as exc:
            self.record(command, who, f"error: {type(exc).__name__}: {exc}")
            self.jogs.failed(command, who, exc)
            raise
        if not face_audits:
            self.record(command, who, "ok")
        self.jogs.carried_out(command, who)
        return result

    async def read(
        self, command: Command[R], *, max_age: float | None = None, who: Who | None = None
    ) -> R:
        """The answer to ``command`` (a read).

        Without ``max_age`` the read is linearizable: it is answered by a wire exchange that
        began after it arrived, shared with identical reads waiting with it (never one already
        on the wire: see :mod:`robostar.serve.reads`). With ``max_age`` (seconds) a model value
        at most that old, and newer than the last state change, answers it without an exchange;
        :meth:`read_sample` gives that value's age too. ``who`` (optional) lets
        :meth:`withdraw` take the read out of the queue."""
        value, _ = await self.read_sample(command, max_age=max_age, who=who)
        return value

    async def read_sample(
        self, command: Command[R], *, max_age: float | None = None, who: Who | None = None
    ) -> tuple[R, float]:
        """:meth:`read`, with the oldest ``time.time()`` its answer may describe the controller
        at: a model value's time, or the start of the exchange that answered (after the read
        arrived)."""
        if command.CHANGES_STATE:
            raise UsageError(f"{command.CODE} changes state: use execute(), with a lease holder")
        if max_age is not None:
            cached = self.feed.answer(command, max_age)
            if cached is not None:
                return cast(R, cached[0]), cached[1]
        if self._reads_waiting >= MAX_QUEUED_READS:
            raise LineBusyError(
                f"line {self.name}: {self._reads_waiting} reads are waiting for the line;"
                " nothing was sent, try again shortly"
            )
        self._check_open()
        command.encode()  # bad input fails here, before it waits in the queue
        self._reads_waiting += 1
        self.poller.consumer_read()
        try:
            result, began = await self.reads.read(command, PRI_REQUEST, who)
        finally:
            self._reads_waiting -= 1
        return cast(R, result), began

    def on_exchange(self, observer: ExchangeObserver) -> Callable[[], None]:
        """Call ``observer(command, result_or_error, who)`` after each exchange the line
        completes, in the worker, before its requester hears of it: ``result_or_error`` is the
        answer, or the exception it ended with (a refusal, a timeout, an abort by a stop); ``who``
        is the requester, None for the poller's reads and for reads shared by several readers.
        So other parts (the web face's program store, a recorder) see uploads, downloads and
        every other exchange without reaching into the line. An observer must be quick and must
        not raise (what it raises is logged and dropped). Returns a function that removes it."""
        self._observers.append(observer)

        def remove() -> None:
            with contextlib.suppress(ValueError):
                self._observers.remove(observer)

        return remove

    def _exchanged(self, job: _Job, outcome: Any) -> None:
        who = job.who if job.shared_by is None else job.shared_by()
        for observer in list(self._observers):
            try:
                observer(job.command, outcome, who)
            except Exception:
                log.exception("line %s: an exchange observer failed", self.name)

    # -- the queue -------------------------------------------------------------------------
    async def _submit(self, command: Command[R], priority: int, who: Who | None) -> R:
        self._check_open()
        return await self._enqueue(command, priority, who)

    def _check_open(self) -> None:
        """LineDownError unless the line can take requests now."""
        if self._stopping:
            raise LineDownError(f"line {self.name}: the server is stopping")
        if not self._up.is_set():
            raise LineDownError(
                f"line {self.name} is down ({self.health.last_error or 'not connected yet'});"
                " nothing was sent"
            )

    def _enqueue(self, command: Command[R], priority: int, who: Who | None) -> asyncio.Future[R]:
        """Queue ``command``; its future gets the result. A job whose future is done (e.g.
        cancelled) before the worker reaches it is skipped."""
        return cast("asyncio.Future[R]", self._enqueue_job(command, priority, who).future)

    def _enqueue_shared(self, command: Command[Any], priority: int) -> _Job:
        """A read flight's job (its readers' ``who`` are the flight's, see :meth:`withdraw`)."""
        self._check_open()
        return self._enqueue_job(command, priority, None)

    def _enqueue_job(self, command: Command[Any], priority: int, who: Who | None) -> _Job:
        """:meth:`_enqueue`, giving the job (whether it has started is known by it)."""
        command.encode()  # bad input fails here, before it waits in the queue or reaches the wire
        future: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        job = _Job(priority, next(self._seq), command, future, who)
        self._queue.put_nowait(job)
        if priority == PRI_STOP:
            self._preempt(command)
        return job

    def _preempt(self, stop: Command[Any]) -> None:
        job, task = self._current, self._current_task
        if job is not None and task is not None and isinstance(job.command, TRANSFERS):
            self._aborted_by = stop
            task.cancel()

    def withdraw(self, who: Who, why: str) -> int:
        """Fail every request of ``who`` still in the queue (not yet sent) with
        :class:`WithdrawnError` saying ``why``: its requester is gone, so no one would see the
        outcome, and a state change must not run for someone no longer there. Stops stay (a
        robot someone asked to stop is stopped all the same); a request already on the wire
        runs to its end. Returns how many were withdrawn."""
        kept: list[_Job] = []
        withdrawn = 0
        while not self._queue.empty():
            job = self._queue.get_nowait()
            if job.who != who or isinstance(job.command, STOPS):
                kept.append(job)
            elif not job.future.done():
                job.future.set_exception(
                    WithdrawnError(
                        f"line {self.name}: {job.command.CODE} withdrawn before it was sent"
                        f" ({why}); nothing was sent"
                    )
                )
                withdrawn += 1
        for job in kept:
            self._queue.put_nowait(job)

        def withdrawn_read(command: Command[Any]) -> WithdrawnError:
            return WithdrawnError(
                f"line {self.name}: {command.CODE} withdrawn before it was sent ({why});"
                " nothing was sent"
            )

        return withdrawn + self.reads.withdraw(who, withdrawn_read)

    def _fail_queued(self, error: BaseException) -> None:
        while not self._queue.empty():
            job = self._queue.get_nowait()
            if not job.future.done():
                job.future.set_exception(error)

    async def _worker(self) -> None:
        attempt = 0
        while True:
            if not self._up.is_set():
                if not await self._connect():
                    self._first_attempt.set()
                    self._fail_queued(
                        LineDownError(f"line {self.name} is down: {self.health.last_error}")
                    )
                    await asyncio.sleep(_RECONNECT.delay(attempt))
                    attempt += 1
                    continue
                attempt = 0
                self._first_attempt.set()
            job = await self._queue.get()
            if job.future.done() or self._lease_lost_before_sending(job):
                continue
            await self._run(job)

    def _lease_lost_before_sending(self, job: _Job) -> bool:
        """Refuse (fail) ``job`` if it needs its requester's lease and the requester no longer
        holds it: the lease was checked when it was queued, but it may have waited behind a
        slow exchange while the requester lost the lease and another took it. Stops need none."""
        refusal = self.gate.refusal_at_send(job.command, job.who)
        if refusal is None:
            return False
        job.future.set_exception(refusal)  # execute() audits the refusal
        return True

    async def _run(self, job: _Job) -> None:
        client = self._client
        assert client is not None
        self._current = job
        job.started = True
        self._aborted_by = None
        started = time.perf_counter()
        job.began = time.time()
        done: list[tuple[int, int | None]] = [(0, None)]

        def progress(count: int, total: int | None) -> None:
            done[0] = (count, total)

        # a transfer reports its progress, so that a stop's victim learns how far it got (only a
        # transfer: a progress hook takes the client off its one-read fast path)
        task = asyncio.create_task(
            client.execute(job.command, progress=progress)
            if isinstance(job.command, TRANSFERS)
            else client.execute(job.command)
        )
        self._current_task = task
        try:
            result = await asyncio.shield(task)
        except asyncio.CancelledError:
            if task.cancelled() and self._aborted_by is not None and not job.future.done():
                # cancelled by a stop: the AsyncClient ended the exchange with RST
                stop = self._aborted_by
                count, total = done[0]
                unit = "lines accepted" if isinstance(job.command, UploadFile) else "packets read"
                of = f" of {total}" if total is not None else ""
                aborted = AbortedByStopError(
                    f"line {self.name}: {job.command.CODE} aborted by stop {stop.CODE}"
                    f" after {count}{of} {unit} (the transfer is incomplete)"
                )
                self._exchanged(job, aborted)
                job.future.set_exception(aborted)
                self._count(started, error=True)
                return
            task.cancel()
            with contextlib.suppress(BaseException):
                await task
            if not job.future.done():
                stopping = f"line {self.name}: the server stopped during the exchange"
                job.future.set_exception(
                    OutcomeUnknownError(job.command.CODE, stopping)
                    if job.command.CHANGES_STATE
                    else LineDownError(stopping)
                )
            raise
        except RobostarError as exc:
            self._count(started, error=True)
            if job.command.CHANGES_STATE:
                # refused or of unknown outcome, it may still have changed something (a BC past
                # the soft limits raises an alarm): no value read before it may answer now
                self._state_changed(None)
            await self._line_trouble(exc)  # first: the waiter then sees the line as it is
            self._exchanged(job, exc)
            if not job.future.done():
                job.future.set_exception(exc)
            return
        except Exception as exc:  # a bug must reach the caller, not kill the worker
            self._count(started, error=True)
            self._exchanged(job, exc)
            if not job.future.done():
                job.future.set_exception(exc)
            return
        finally:
            self._current = None
            self._current_task = None
        self._timeouts = 0
        self._count(started, error=False)
        if job.command.CHANGES_STATE:
            self._state_changed(changed_by(job.command))
        self._exchanged(job, result)
        if not job.future.done():
            job.future.set_result(result)

    def _state_changed(self, changed: frozenset[str] | None) -> None:
        """A state change went out: the model is not vouched for until read again, and the
        poller reads again at once what it may have changed (``changed``: those model keys
        beside status and positions; None: everything), so subscribers see the effect
        promptly."""
        self.model.invalidate()
        if changed is None:
            # it may move a robot or raise an alarm: the status vouches for nothing read before
            self.feed.witness.unsettle()
        self.poller.state_changed(changed)

    def _count(self, started: float, *, error: bool) -> None:
        self.health.count(time.perf_counter() - started, error=error)

    async def _line_trouble(self, exc: RobostarError) -> None:
        self.health.last_error = f"{type(exc).__name__}: {exc}"
        if isinstance(exc, ReplyTimeoutError):
            self._timeouts += 1
            if self._timeouts < _MAX_TIMEOUTS:
                return
        elif not isinstance(exc, PortError):
            return
        log.warning("line %s down: %s", self.name, exc)
        await self._close_client()
        self._set_down(self.health.last_error)

    async def _connect(self) -> bool:
        client: AsyncClient | None = None
        try:
            client = self._client_factory(self.config)
            await client.connect()
            info = await client.execute(ReadInfo())
        except Exception as exc:  # whatever it is, the line is down: the worker must live on
            if client is not None:
                with contextlib.suppress(Exception):
                    await client.close()
            if not isinstance(exc, RobostarError):
                log.error("line %s: cannot open %s", self.name, self.config.url, exc_info=exc)
            self.health.last_error = f"{type(exc).__name__}: {exc}"
            self.health.errors += 1
            return False
        if self.health.exchanges or self.health.reconnects or self.info is not None:
            self.health.reconnects += 1
        self._client = client
        self.info = info
        self.feed.present = _channels_of(info)
        missing = sorted(set(self.config.channels) - set(self.feed.present))
        if missing:
            log.warning(
                "line %s: channel(s) %s configured, but the controller has no robot there",
                self.name,
                ", ".join(map(str, missing)),
            )
        self.poller.line_opened()
        self.feed.witness.unsettle()
        self.model.set("info", info)
        self.model.set("online", True)
        self._timeouts = 0
        self.health.up = True
        self._up.set()
        log.info("line %s up: %s %s", self.name, info.name, info.version)
        return True

    async def _close_client(self) -> None:
        client, self._client = self._client, None
        if client is not None:
            with contextlib.suppress(RobostarError, OSError):
                await client.close()

    def _set_down(self, reason: str | None) -> None:
        self._up.clear()
        self.health.up = False
        if reason:
            self.health.last_error = reason
        self.model.mark(Quality.LINE_DOWN)
        self.feed.witness.unsettle()
        self.model.set("online", False)

    # -- the jogs --------------------------------------------------------------------------
    def _takes_requests(self) -> bool:
        return self._up.is_set() and not self._stopping

    async def _send_jog_stop(self, channel: int) -> None:
        await self._submit(JogStop(channel), PRI_STOP, None)

    def record(self, command: Command[Any] | str, who: Who, outcome: str) -> None:
        """One audit entry for this line: what ``who`` asked (a command, or a name when the
        request never became one) and how it ended. Faces that refuse a request themselves
        record it here too."""
        what = command if isinstance(command, str) else _describe(command)
        self.audit.write(line=self.name, who=who.name, face=who.face, what=what, outcome=outcome)

    # -- the model -------------------------------------------------------------------------
    def _answered(self, command: Command[Any], result: Any, began: float) -> None:
        """A read flight's answer (a consumer's or the poller's): into the model, stamped with
        the start of its exchange (the oldest instant it may describe)."""
        self.feed.store(command, result, began)

    def channels(self) -> tuple[int, ...]:
        """The channels of this line the poller reads and the faces show: those the controller
        has (its AD answer: a robot with axes in use), of the configured ones when configured;
        before the controller has answered, the configured ones, else channel 1."""
        configured = tuple(sorted(self.config.channels))
        if self.info is None:
            return configured or (1,)
        has = _channels_of(self.info)
        if not configured:
            return has
        return tuple(c for c in configured if c in has)

    async def wait_polled(self, timeout: float = 5.0) -> None:
        """Wait until a complete poll cycle has ended after now (tests, the CLI's start-up)."""
        await self.poller.wait_polled(timeout)


def _cancelled_outcome(job: _Job | None) -> str:
    """The audit outcome of a state change whose requester was cancelled while it waited."""
    if job is None or not job.started:
        return "cancelled, not sent"  # the worker skips a job whose future is done
    future = job.future
    if future.done() and not future.cancelled() and future.exception() is None:
        return "ok (the requester went away before its answer)"
    return "outcome unknown: the requester went away while it was on the wire"


def _channels_of(info: ControllerInfo) -> tuple[int, ...]:
    """The channels the controller has: a robot with axes in use (channel 1 at least)."""
    return tuple(c.channel for c in info.channels if c.axes_in_use) or (1,)


def _default_client(config: LineConfig) -> AsyncClient:
    options: dict[str, Any] = {}
    if config.baudrate is not None:
        options["baudrate"] = config.baudrate
    return AsyncClient(config.url, timeout=config.timeout, **options)
