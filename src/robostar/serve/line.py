"""One controller line: a worker owning its AsyncClient, a priority queue, the poller and the lease.

Every exchange on the line goes through one queue served by one worker, so consumers never
interleave on the wire (as mbusd serialises Modbus TCP clients onto one RTU line). Stops (CF, CD,
CI, BG) go first and cancel a transfer in progress; a jog keepalive (BF) goes next; then writes,
consumers' reads and last the poller's reads.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar, cast

from robostar.client.aio import AsyncClient
from robostar.commands.base import Command
from robostar.commands.control import EmergencyStop, ReadSpeed, StopHoming, StopJob
from robostar.commands.files import DownloadFile, ReadAlarmHistory, UploadFile
from robostar.commands.io import ReadInputs, ReadOutputs
from robostar.commands.job import ReadJobName, ReadJobStep
from robostar.commands.motion import JogContinue, JogStart, JogStop
from robostar.commands.status import ReadAlarms, ReadInfo, ReadPosition, ReadStatus
from robostar.errors import (
    ControllerError,
    LineError,
    NotSupportedError,
    OutcomeUnknownError,
    PortError,
    ReplyTimeoutError,
    RobostarError,
    UsageError,
)
from robostar.serve.audit import AuditLog
from robostar.serve.config import LineConfig
from robostar.serve.lease import Lease, LeaseHeldError, LeaseInfo, Who
from robostar.serve.line_queue import (
    PRI_KEEPALIVE,
    PRI_LATE_POLL,
    PRI_POLL,
    PRI_READ,
    PRI_STOP,
    PRI_WRITE,
)
from robostar.serve.line_queue import Job as _Job
from robostar.serve.model import ControllerModel, Quality
from robostar.serve.reads import ReadFlights
from robostar.types import ControllerInfo, PositionKind

__all__ = [
    "STOPS",
    "AbortedByStopError",
    "ExchangeObserver",
    "LeaseLostError",
    "Line",
    "LineDownError",
    "LineHealth",
    "WithdrawnError",
    "model_key",
]

R = TypeVar("R")
ExchangeObserver = Callable[[Command[Any], Any, "Who | None"], None]
"""Called after each completed exchange: (command, its result or the error it ended with, who
asked: None for the poller's and for reads shared by several readers)."""
log = logging.getLogger("robostar.serve")

STOPS = (EmergencyStop, StopJob, StopHoming, JogStop)
"""CF, CD, CI, BG: anyone may send them (no lease), and they jump every queue."""
_TRANSFERS = (UploadFile, DownloadFile, ReadAlarmHistory)
"""Long multi-packet exchanges a stop cancels rather than waits for."""

_STEADY_KEYS = frozenset(("info", "online"))
"""Model values set when the line opens or closes, not by the poller."""
MAX_QUEUED_READS = 256
"""Consumers' reads waiting for the line at once; past it a read is refused (LineBusyError)
instead of making every later request, and the poller, wait behind it."""
_MAX_TIMEOUTS = 3
"""Consecutive reply timeouts after which the line is taken for down and reopened."""
_BACKOFF = (0.2, 0.5, 1.0, 2.0, 5.0, 10.0)


class LineDownError(LineError):
    """The line is down (or the server is stopping); nothing was sent."""


class LineBusyError(LineError):
    """Too many reads are waiting for this line; nothing was sent. Try again shortly."""


def stale_after(config: LineConfig) -> float:
    """Seconds without a complete poll after which the model's values are no longer vouched
    for (marked STALE), and the poller's reads jump ahead of the consumers'."""
    return max(5 * config.poll_interval, 2 * config.slow_interval)


class AbortedByStopError(LineError):
    """A transfer in progress was cancelled so that a stop could go out at once."""


class LeaseLostError(LeaseHeldError):
    """A state change waited in the queue while its requester lost the lease (expiry, release,
    a disconnect, a takeover); it was refused just before sending: nothing was sent.

    A :class:`LeaseHeldError`, so faces answer it as they answer any lease conflict."""

    def __init__(self, line: str, command: str, who: Who, holder: LeaseInfo | None) -> None:
        now = f"control is held by {holder.who}" if holder is not None else "the lease is free"
        # not LeaseHeldError's own text ("control is held by ..."): the point is the loss
        RobostarError.__init__(
            self,
            f"line {line}: {command} for {who} refused: the lease was lost before it was sent"
            f" ({now}); nothing was sent",
        )
        self.line = line
        self.holder = holder  # None: the lease is free, as LeaseHeldError has it


class WithdrawnError(LineError):
    """A request was taken out of the queue before it was sent, because its requester went away
    (an N1 connection closed, a host gave the exchange up); nothing was sent."""


@dataclass
class LineHealth:
    """What a dashboard or a metrics scrape wants to know about a line."""

    up: bool = False
    last_error: str | None = None
    latency: float | None = None
    """Duration of the last exchange, seconds."""
    exchanges: int = 0
    errors: int = 0
    reconnects: int = 0
    last_poll: float | None = None
    """``time.time()`` of the end of the last complete poll cycle."""
    latencies: list[float] = field(default_factory=list, repr=False)
    """Recent exchange durations (bounded), for the metrics histogram."""

    @property
    def poll_age(self) -> float | None:
        return None if self.last_poll is None else max(0.0, time.time() - self.last_poll)


def model_key(command: Command[Any]) -> str | None:
    """The model key that answers ``command`` (a read), or None if the model cannot."""
    match command:
        case ReadInfo():
            return "info"
        case ReadAlarms():
            return "alarms"
        case ReadAlarmHistory():
            return "alarm_history"
        case ReadPosition(channel=ch, kind=PositionKind.XY):
            return f"ch{ch}/position"
        case ReadPosition(channel=ch, kind=PositionKind.ANGLE):
            return f"ch{ch}/angles"
        case ReadSpeed(channel=ch):
            return f"ch{ch}/speed"
        case ReadJobName(channel=ch):
            return f"ch{ch}/job"
        case ReadJobStep(channel=ch):
            return f"ch{ch}/step"
        case ReadInputs(port=port):
            return f"io/in/{port}"
        case ReadOutputs(port=port):
            return f"io/out/{port}"
    return None


def _describe(command: Command[Any]) -> str:
    return repr(command) if len(repr(command)) <= 200 else f"{command.CODE}(...)"


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
        self._jogs: dict[int, Who] = {}
        self._unsupported: set[str] = set()
        """Poll reads the controller answered 0x33 (not supported): not asked again until the
        line reopens (by :func:`model_key`, else the command's code)."""
        self._poll_now = asyncio.Event()
        self._reads_waiting = 0
        self.reads = ReadFlights(self._enqueue_shared, self._answered)
        """The line's reads, coalesced: consumers' and the poller's alike."""
        self._written = False
        self.info: ControllerInfo | None = None
        self._observers: list[ExchangeObserver] = []
        self.lease.on_lost.append(self._lease_lost)
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
            asyncio.create_task(self._poller(), name=f"line {self.name} poller"),
            asyncio.create_task(self._watch_staleness(), name=f"line {self.name} staleness"),
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
            for channel in list(self._jogs):
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
    async def execute(self, command: Command[R], *, who: Who, implicit_lease: bool = False) -> R:
        """Run ``command`` for ``who`` through the queue (state changes need the lease)."""
        if not command.CHANGES_STATE:
            return await self.read(command)
        is_stop = isinstance(command, STOPS)
        if not is_stop:
            try:
                self.audit.ready()  # nothing moves that the log cannot record (stops do)
                if self.lease.held_by(who) or implicit_lease:
                    self.lease.acquire(who)
                else:
                    self.lease.renew(who)
            except RobostarError as exc:
                self.record(command, who, f"refused: {exc}")
                raise
        priority = PRI_STOP if is_stop else PRI_WRITE
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
            if isinstance(command, JogStart) and outcome.startswith("outcome unknown"):
                self._stop_unsure_jog(command.channel, who)
            raise
        except LeaseLostError as exc:
            self.record(command, who, f"refused: {exc}")
            raise
        except WithdrawnError as exc:
            self.record(command, who, f"cancelled, not sent: {exc}")
            raise
        except BaseException as exc:
            self.record(command, who, f"error: {type(exc).__name__}: {exc}")
            if isinstance(command, JogStart) and isinstance(exc, OutcomeUnknownError):
                self._stop_unsure_jog(command.channel, who)
            raise
        self.record(command, who, "ok")
        if isinstance(command, JogStart):
            self._jogs[command.channel] = who
        elif isinstance(command, JogStop):
            self._jogs.pop(command.channel, None)
        elif isinstance(command, EmergencyStop):
            self._jogs.clear()
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
            cached = self._from_model(command, max_age)
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
        try:
            result, began = await self.reads.read(command, PRI_READ, who)
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
        if job is not None and task is not None and isinstance(job.command, _TRANSFERS):
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
                    await asyncio.sleep(_BACKOFF[min(attempt, len(_BACKOFF) - 1)])
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
        command, who = job.command, job.who
        if who is None or not command.CHANGES_STATE or isinstance(command, STOPS):
            return False
        if self.lease.held_by(who):
            return False
        job.future.set_exception(
            LeaseLostError(self.name, command.CODE, who, self.lease.holder)
        )  # execute() audits the refusal
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
            if isinstance(job.command, _TRANSFERS)
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
                self._state_changed()
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
            self._state_changed()
        self._exchanged(job, result)
        if not job.future.done():
            job.future.set_result(result)

    def _state_changed(self) -> None:
        """A state change went out: the model is not vouched for until read again, and the
        poller reads it all again at once, so subscribers see the effect promptly."""
        self.model.invalidate()
        self._written = True
        self._poll_now.set()

    def _count(self, started: float, *, error: bool) -> None:
        elapsed = time.perf_counter() - started
        self.health.exchanges += 1
        self.health.latency = elapsed
        self.health.latencies.append(elapsed)
        if len(self.health.latencies) > 1000:
            del self.health.latencies[:500]
        if error:
            self.health.errors += 1

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
        # the line may lead to another controller (or the same one reconfigured) now: what it
        # did not support before is asked again
        self._unsupported.clear()
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
        self.model.set("online", False)

    # -- the lease -------------------------------------------------------------------------
    def _lease_lost(self, who: Who) -> None:
        for channel, holder in list(self._jogs.items()):
            if holder == who and self._stop_jog_soon(channel, who, "lease lost"):
                self._jogs.pop(channel, None)

    def _stop_unsure_jog(self, channel: int, who: Who) -> None:
        """A jog start whose outcome is unknown may have set the axis moving, and nobody will
        keep it alive: stop it now rather than leave it to the controller's watchdog."""
        self._stop_jog_soon(channel, who, "its start's outcome was unknown")

    def _stop_jog_soon(self, channel: int, who: Who, why: str) -> bool:
        """BG for ``channel`` from a task of its own (audited with ``why``), while the line is
        up and the server not stopping; False when not sent (a jog kept in ``_jogs`` is then
        stopped as the server stops)."""
        if not self._up.is_set() or self._stopping:
            return False
        task = asyncio.get_running_loop().create_task(self._stop_jog(channel, who, why))
        task.add_done_callback(_ignore_result)
        return True

    async def _stop_jog(self, channel: int, who: Who, why: str) -> None:
        try:
            await self._submit(JogStop(channel), PRI_STOP, None)
        except RobostarError as exc:
            self.record(JogStop(channel), who, f"error: {why}, jog stop failed: {exc}")
            raise
        self.record(JogStop(channel), who, f"jog stopped: {why}")

    def record(self, command: Command[Any] | str, who: Who, outcome: str) -> None:
        """One audit entry for this line: what ``who`` asked (a command, or a name when the
        request never became one) and how it ended. Faces that refuse a request themselves
        record it here too."""
        what = command if isinstance(command, str) else _describe(command)
        self.audit.write(line=self.name, who=who.name, face=who.face, what=what, outcome=outcome)

    # -- the model -------------------------------------------------------------------------
    def _from_model(self, command: Command[Any], max_age: float) -> tuple[Any, float] | None:
        """The model's answer to ``command`` and its time, if good and at most ``max_age`` old."""
        if isinstance(command, ReadStatus):
            samples = [self.model.fresh(f"ch{n}/status", max_age) for n in (1, 2, 3)]
            if all(s is not None for s in samples):
                good = [s for s in samples if s is not None]
                return tuple(s.value for s in good), min(s.at for s in good)
            return None
        key = model_key(command)
        if key is None:
            return None
        sample = self.model.fresh(key, max_age)
        return None if sample is None else (sample.value, sample.at)

    def _answered(self, command: Command[Any], result: Any, began: float) -> None:
        """A read flight's answer (a consumer's or the poller's): into the model, stamped with
        the start of its exchange (the oldest instant it may describe)."""
        self._store(command, result, began)

    def _store(self, command: Command[Any], result: Any, at: float | None = None) -> None:
        if at is not None and math.isnan(at):
            at = None
        if isinstance(command, ReadStatus):
            for n, status in enumerate(result, start=1):
                self.model.set(f"ch{n}/status", status, at)
            return
        key = model_key(command)
        if key is not None:
            self.model.set(key, result, at)

    def channels(self) -> tuple[int, ...]:
        """The channels the poller reads: the configured ones, else those the controller has."""
        if self.config.channels:
            return tuple(sorted(self.config.channels))
        if self.info is not None:
            return tuple(c.channel for c in self.info.channels if c.axes_in_use) or (1,)
        return (1,)

    async def _poller(self) -> None:
        next_slow = 0.0
        next_history = 0.0
        while True:
            await self._up.wait()
            started = time.monotonic()
            # cleared as the cycle starts, not as it ends: a write that lands during the cycle
            # sets it again and the next cycle starts at once (it would be lost otherwise)
            self._poll_now.clear()
            try:
                fast: list[Command[Any]] = [ReadStatus()]
                for ch in self.channels():
                    fast.append(ReadPosition(ch, PositionKind.XY))
                    fast.append(ReadPosition(ch, PositionKind.ANGLE))
                if started >= next_slow or self._written:
                    self._written = False
                    next_slow = started + self.config.slow_interval
                    fast.append(ReadAlarms())
                    for ch in self.channels():
                        fast += [ReadSpeed(ch), ReadJobName(ch), ReadJobStep(ch)]
                    for port in self.config.io_ports:
                        fast += [ReadInputs(port), ReadOutputs(port)]
                if started >= next_history:
                    next_history = started + self.config.history_interval
                    fast.append(ReadAlarmHistory())
                for command in fast:
                    await self._poll_one(command)
                self.health.last_poll = time.time()
            except LineDownError:
                await asyncio.sleep(0.05)
                continue
            except RobostarError as exc:
                log.debug("line %s poll: %s", self.name, exc)
                # the values are what they were, but nobody can vouch for them now; "online"
                # and "info" are the line's own, set as it opens or drops (a poll failing as
                # the line dropped made its "online: false" stale)
                self.model.age_out(math.inf, keep=_STEADY_KEYS)
            delay = self.config.poll_interval - (time.monotonic() - started)
            # asyncio.wait, not wait_for: on Python 3.11 wait_for can swallow a cancellation
            # that races with the event, and stop() would wait forever for the poller.
            waiter = asyncio.ensure_future(self._poll_now.wait())
            try:
                await asyncio.wait({waiter}, timeout=max(0.0, delay))
            finally:
                waiter.cancel()

    async def _watch_staleness(self) -> None:
        """Mark the model's good values STALE while no poll has completed for a while (a
        starved or stuck poller): a value nobody re-read must not keep saying "good"."""
        limit = stale_after(self.config)
        while True:
            await asyncio.sleep(self.config.poll_interval)
            age = self.health.poll_age
            if self._up.is_set() and age is not None and age > limit:
                self.model.age_out(time.time() - limit, keep=_STEADY_KEYS)

    async def _poll_one(self, command: Command[Any]) -> None:
        key = model_key(command) or command.CODE
        if key in self._unsupported:
            return
        try:
            await self._poll_read(command)
        except NotSupportedError as exc:
            # 0x33: a channel without a robot, an option the controller lacks: stop asking. The
            # value it had (if any) is not vouched for any more.
            log.info("line %s: %s not polled any more (%s)", self.name, key, exc)
            self._unsupported.add(key)
            self._mark_stale(command)
            return
        except ControllerError as exc:
            # 0x31/0x32 ("cannot be done now"): a refusal of this moment, not of the value: ask
            # again next cycle; meanwhile the old value must not say "good"
            log.debug("line %s: poll of %s refused (%s)", self.name, key, exc)
            self._mark_stale(command)
            return

    def _mark_stale(self, command: Command[Any]) -> None:
        """Mark STALE the good model values that ``command`` (a poll read) refreshes."""
        if isinstance(command, ReadStatus):
            keys = {f"ch{n}/status" for n in (1, 2, 3)}
        else:
            key = model_key(command)
            keys = set() if key is None else {key}
        if keys:
            # the model marks by age, not by key: every other key is kept out of it
            others = self.model.snapshot().keys() - keys
            self.model.age_out(math.inf, keep=others)

    async def _poll_read(self, command: Command[R]) -> R:
        """A poll read, a flight like a consumer's (its answer refreshes the model): behind
        the consumers' reads, until the model would go stale waiting; from then on ahead of
        them."""
        limit = stale_after(self.config)
        age = self.health.poll_age or 0.0
        self._check_open()
        late = age > limit
        answer = self.reads.read(command, PRI_LATE_POLL if late else PRI_POLL, None)
        if not late:
            try:
                done, _ = await asyncio.wait({answer}, timeout=limit - age)
            except asyncio.CancelledError:
                answer.cancel()
                raise
            if not done:
                self.reads.hurry(command, PRI_LATE_POLL)
        result, _ = await answer  # cancelled with the poller: the flight drops it
        return cast(R, result)

    async def wait_polled(self, timeout: float = 5.0) -> None:
        """Wait until a complete poll cycle has ended after now (tests, the CLI's start-up)."""
        since = time.time()

        async def cycle() -> None:
            while self.health.last_poll is None or self.health.last_poll < since:
                await asyncio.sleep(0.01)

        await asyncio.wait_for(cycle(), timeout)


def _cancelled_outcome(job: _Job | None) -> str:
    """The audit outcome of a state change whose requester was cancelled while it waited."""
    if job is None or not job.started:
        return "cancelled, not sent"  # the worker skips a job whose future is done
    future = job.future
    if future.done() and not future.cancelled() and future.exception() is None:
        return "ok (the requester went away before its answer)"
    return "outcome unknown: the requester went away while it was on the wire"


def _ignore_result(task: asyncio.Task[Any]) -> None:
    if not task.cancelled():
        task.exception()


def _default_client(config: LineConfig) -> AsyncClient:
    options: dict[str, Any] = {}
    if config.baudrate is not None:
        options["baudrate"] = config.baudrate
    return AsyncClient(config.url, timeout=config.timeout, **options)
