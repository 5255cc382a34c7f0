"""The virtual controller: the simulator's N1 serving backend, and a byte peer for one line.

:class:`VirtualController` is a :class:`~robostar.controller_role.Backend`: each
:class:`~robostar.controller_role.ControllerSession` (one per connection, :meth:`open_session`)
decodes requests with the command catalogue and hands them here; the handlers act on the shared
:class:`~robostar.sim.model.Model` and the answer goes back to the session that asked. Used directly
as a :class:`~robostar.transport.peer.BytePeer` it serves one line (its own default session). It
owns no thread and no clock: the driver passes real monotonic time into every call; model time runs
``speedup`` times faster. Link timeouts and the jog watchdog stay in real seconds.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Any, Protocol

from robostar.commands.base import Command
from robostar.commands.files import UploadFile
from robostar.commands.motion import JogContinue, JogStart
from robostar.controller_role import Backend, ControllerSession, Refusal, Request, UploadLimits
from robostar.errors import FieldError
from robostar.sim.config import SimConfig
from robostar.sim.dialects import dialect_named
from robostar.sim.handlers import Deferred, Reply, Upload, handle
from robostar.sim.journal import Journal, Observer
from robostar.sim.model import Model, Refused, Timer

__all__ = ["JOG_WATCHDOG", "StateStoreLike", "VirtualController"]

JOG_WATCHDOG = 0.5
"""Real seconds a jog runs on after BE or the last BF."""


class StateStoreLike(Protocol):
    """Where the controller keeps its state across runs (see robostar.sim.store)."""

    def load(self) -> dict[str, Any] | None: ...

    def save(self, snapshot: dict[str, Any]) -> None: ...


@dataclass
class _SecondPhase:
    """A two-phase answer waiting for its work to finish."""

    request: Request
    timer: Timer


class VirtualController(Backend):
    """A virtual N1 controller: the serving backend of any number of sessions, and a
    :class:`~robostar.transport.peer.BytePeer` for one line (its default :attr:`session`).

    ``model`` is open to tests (``model.set_input``, ``model.raise_alarm``, positions, files,
    globals); ``executions`` counts how often each state-changing command was carried out and
    ``requests`` how many request packets arrived, over every session. With a ``store``, the
    state is loaded at start and saved after every change, before the answer that reports it.
    """

    def __init__(
        self,
        config: SimConfig | None = None,
        *,
        store: StateStoreLike | None = None,
        limits: UploadLimits | None = None,
        journal: Journal | None = None,
    ):
        self.config = config or SimConfig()
        self.model = Model(self.config)
        self.dialect = dialect_named(self.config.dialect)
        self.limits = limits or UploadLimits()
        self.executions: Counter[str] = Counter()
        self._store = store
        self._last_now: float | None = None
        self._jog_deadlines: dict[int, float] = {}
        self._seconds: list[_SecondPhase] = []
        self._sessions: list[ControllerSession] = []
        self._closed_requests = 0
        if store is not None:
            snapshot = store.load()
            if snapshot is not None:
                self.model.restore(snapshot)
        if journal is None and self.config.journal is not None:
            journal = Journal(self.config.journal)
        self.journal = journal
        """Where every state change goes (robostar.sim.journal), or None."""
        self._observer = (
            Observer(journal, self.model, self.config.name) if journal is not None else None
        )
        self._saved = self.model.revision
        self.session = self.open_session("line")
        """The session of the one line served when this object is used as a byte peer."""

    @property
    def link(self) -> Any:
        """The default session's controller link."""
        return self.session.link

    @property
    def requests(self) -> int:
        """Request packets received, over every session."""
        return self._closed_requests + sum(s.requests for s in self._sessions)

    # -- sessions --------------------------------------------------------------------------------
    def open_session(self, name: str = "n1") -> ControllerSession:
        """A new N1 session (one connection) on this controller."""
        session = ControllerSession(
            self, timeout=self.config.ack_timeout, limits=self.limits, name=name
        )
        self._sessions.append(session)
        return session

    paced = False
    """Sessions on the controller itself keep no line timing (see SimSessions for that)."""

    def close_session(self, peer: Any) -> None:
        """The connection of a session from :meth:`open_session` is gone."""
        if isinstance(peer, ControllerSession):
            peer.close()

    def session_closed(self, session: ControllerSession) -> None:
        if session in self._sessions:
            self._sessions.remove(session)
            self._closed_requests += session.requests

    def poll(self, now: float) -> None:
        """Advance to ``now``: model time, jog watchdogs, due second answers, saving."""
        self._advance(now)
        self._settle()
        if self._observer is not None and self._last_now is not None:
            # the model's own time: a kernel's arrival stamp may be older than the last poll
            self._observer.observe(self._last_now)

    def shared_deadline(self) -> float | None:
        """The next real time the model needs :meth:`poll`: a two-phase answer, the end of a
        motion or a job step, a jog watchdog."""
        times = list(self._jog_deadlines.values())
        event = self.model.next_event()
        if event is not None and self._last_now is not None:
            ahead = max(0.0, event - self.model.clock) / self.config.speedup
            times.append(self._last_now + ahead)
        return min(times, default=None)

    # -- BytePeer (the default session) ----------------------------------------------------------
    def feed(self, data: bytes, now: float) -> None:
        """Bytes the host wrote."""
        self.poll(now)
        self.session.feed(data, now)
        self._settle()

    def output(self, now: float) -> bytes:
        """Advance to ``now`` and return the bytes for the host."""
        self.poll(now)
        out = self.session.output(now)
        self._settle()
        return out + self.session.output(now)

    def next_deadline(self) -> float | None:
        times = [t for t in (self.shared_deadline(), self.session.next_deadline()) if t is not None]
        return min(times, default=None)

    # -- time ------------------------------------------------------------------------------------
    def _advance(self, now: float) -> None:
        if self._last_now is None:
            self._last_now = now
            if self._observer is not None:
                self._observer.start(now)
            return
        # A jog whose watchdog ran out stops where it was at that moment.
        while True:
            due = [(t, ch) for ch, t in self._jog_deadlines.items() if t <= now]
            if not due:
                break
            at, channel = min(due)
            self._run_model_to(at)
            self.model.stop_jog(channel)
            del self._jog_deadlines[channel]
        self._run_model_to(now)

    def _run_model_to(self, now: float) -> None:
        assert self._last_now is not None
        # Called even when no time passed: what is due at this instant happens now.
        self.model.advance(max(0.0, now - self._last_now) * self.config.speedup)
        self._last_now = max(self._last_now, now)

    def _settle(self) -> None:
        """Forget watchdogs of stopped jogs, hand due second answers to their sessions, and
        save what changed."""
        for channel in list(self._jog_deadlines):
            if self.model.channel(channel).jog is None:
                del self._jog_deadlines[channel]
        self._persist()
        waiting: list[_SecondPhase] = []
        for second in self._seconds:
            request = second.request
            if not request.live:
                continue
            if not second.timer.done:
                waiting.append(second)
            elif second.timer.failure is not None:
                failure = second.timer.failure
                request.refuse(failure.reason, failure.flag)
            else:
                request.finish()
        self._seconds = waiting

    # -- the backend -----------------------------------------------------------------------------
    def dress_answer(self, command: Command[Any], packets: list[bytes]) -> list[bytes]:
        return self.dialect.dress(command, packets)

    def note_error(self, session: ControllerSession, text: str) -> None:
        self.model.last_error = text

    def begin_upload(self, session: ControllerSession, command: UploadFile) -> None:
        try:
            self._outcome(command)
        except Refusal as refusal:
            self._journal(session, command, "refused", refusal.reason)
            raise

    def handle(self, request: Request) -> None:
        command = request.command
        try:
            self._carry_out(request)
        except Refusal as refusal:
            if command.CHANGES_STATE:
                self._journal(request.session, command, "refused", refusal.reason)
            raise
        if command.CHANGES_STATE:
            self._journal(request.session, command, "done")

    def _journal(
        self, session: ControllerSession, command: Command[Any], result: str, reason: str = ""
    ) -> None:
        if self._observer is not None:
            now = self._last_now if self._last_now is not None else 0.0
            self._observer.command(now, session.name, command, result, reason or None)

    def _carry_out(self, request: Request) -> None:
        command = request.command
        outcome = self._outcome(command)
        if isinstance(outcome, Upload):
            self.model.store_upload(
                outcome.channel,
                outcome.file,
                outcome.job_number,
                list(command.lines) if isinstance(command, UploadFile) else [],
                request.points,
            )
            self.executions[command.CODE] += 1
            self._persist()
            request.answer(None)
            return
        if command.CHANGES_STATE:
            self.executions[command.CODE] += 1
        self._persist()
        if isinstance(outcome, Reply):
            self._reply(request, outcome)
        else:
            self._defer(request, outcome)

    def _outcome(self, command: Command[Any]) -> Reply | Deferred | Upload:
        try:
            return handle(self.model, command)
        except Refused as exc:
            raise Refusal(exc.reason, exc.flag) from exc

    def _reply(self, request: Request, reply: Reply) -> None:
        command = request.command
        try:
            request.answer(reply.result)
        except FieldError as exc:
            # The state holds something the answer's fields cannot carry.
            request.refuse(str(exc), Refused(str(exc)).flag)
            return
        if isinstance(command, JogStart | JogContinue) and self._last_now is not None:
            self._jog_deadlines[command.channel] = self._last_now + JOG_WATCHDOG

    def _defer(self, request: Request, deferred: Deferred) -> None:
        timer = self.model.schedule(deferred.duration, deferred.finish)
        self.model.advance(0.0)  # work that takes no time is done at once
        if deferred.wait is None:
            request.answer(None)
        else:
            real = deferred.duration / self.config.speedup
            request.answer(min(deferred.wait, math.ceil(real)))
        self._seconds.append(_SecondPhase(request, timer))
        self._settle()

    def _persist(self) -> None:
        if self._store is not None and self.model.revision != self._saved:
            self._store.save(self.model.snapshot())
            self._saved = self.model.revision
