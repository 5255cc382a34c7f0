"""The virtual controller as a byte peer: the controller's link, the command codecs and the model.

:class:`VirtualController` feeds the host's bytes to a
:class:`~robostar.protocol.link.ControllerLink`, decodes each request with the command catalogue
(the same codecs the client uses, in the controller role), lets the handlers act on the
:class:`~robostar.sim.model.Model`, and answers. It owns no thread and no clock: the driver
passes real monotonic time into every call; model time runs ``speedup`` times faster. Link
timeouts and the jog watchdog stay in real seconds.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Protocol

from robostar.commands import COMMANDS, decode_request
from robostar.commands.base import Command
from robostar.commands.files import UploadFile, parse_point_line
from robostar.commands.motion import JogContinue, JogStart
from robostar.commands.system import MAX_TEXT
from robostar.errors import FieldError
from robostar.protocol.fields import FLAG_FAILED, FLAG_REJECTED, FLAG_UNSUPPORTED
from robostar.protocol.frame import CorruptReason
from robostar.protocol.link import (
    After,
    ControllerLink,
    ExchangeFailed,
    FailReason,
    LinkEvent,
    RequestReceived,
    State,
    UploadPacketReceived,
)
from robostar.protocol.packets import make_answer
from robostar.sim.config import SimConfig
from robostar.sim.handlers import Deferred, Reply, Upload, handle
from robostar.sim.model import Model, Refused, Timer
from robostar.types import Point

__all__ = ["JOG_WATCHDOG", "StateStoreLike", "VirtualController"]

JOG_WATCHDOG = 0.5
"""Real seconds a jog runs on after BE or the last BF."""

_CORRUPT_TEXT = {
    CorruptReason.BAD_LRC: "LRC is different with received data LRC",
    CorruptReason.TOO_LONG: "packet is longer than 250 bytes",
    CorruptReason.TRUNCATED: "packet was cut short by a new STX",
}


class StateStoreLike(Protocol):
    """Where the controller keeps its state across runs (see robostar.sim.store)."""

    def load(self) -> dict[str, Any] | None: ...

    def save(self, snapshot: dict[str, Any]) -> None: ...


@dataclass
class _SecondPhase:
    """A two-phase answer waiting for its work to finish."""

    command: Command[Any]
    timer: Timer
    packet: bytes


@dataclass
class _UploadSession:
    """An FB upload in progress: its lines are stored only on the closing 0x34."""

    command: Command[Any]
    target: Upload
    lines: list[str] = field(default_factory=list)
    points: dict[int, Point] = field(default_factory=dict)


class VirtualController:
    """A virtual N1 controller, driven as a :class:`~robostar.transport.peer.BytePeer`.

    ``model`` is open to tests (``model.set_input``, ``model.raise_alarm``, positions, files,
    globals); ``executions`` counts how often each state-changing command was carried out and
    ``requests`` how many request packets arrived. With a ``store``, the state is loaded at
    start and saved after every change, before the answer that reports it is sent.
    """

    def __init__(self, config: SimConfig | None = None, *, store: StateStoreLike | None = None):
        self.config = config or SimConfig()
        self.model = Model(self.config)
        self.link = ControllerLink(timeout=self.config.ack_timeout)
        self.executions: Counter[str] = Counter()
        self.requests = 0
        self._store = store
        self._last_now: float | None = None
        self._jog_deadlines: dict[int, float] = {}
        self._second: _SecondPhase | None = None
        self._upload: _UploadSession | None = None
        if store is not None:
            snapshot = store.load()
            if snapshot is not None:
                self.model.restore(snapshot)
        self._saved = self.model.revision

    # -- BytePeer --------------------------------------------------------------------------------
    def receive_data(self, data: bytes, now: float) -> None:
        """Bytes the host wrote."""
        self._advance(now)
        corrupt_before = self.link.corrupt_frames
        events = self.link.receive_data(data, now)
        if self.link.corrupt_frames != corrupt_before and self.link.last_corrupt is not None:
            self._error(_CORRUPT_TEXT[self.link.last_corrupt])
        self._dispatch(events, now)
        self._settle(now)

    def data_to_send(self, now: float) -> bytes:
        """Advance to ``now`` and return the bytes for the host."""
        self._advance(now)
        self._dispatch(self.link.handle_timeout(now), now)
        self._settle(now)
        return self.link.data_to_send()

    def next_deadline(self) -> float | None:
        """The next real time something happens: a link timer, a two-phase answer, the end of a
        motion or a job step, a jog watchdog."""
        times = list(self._jog_deadlines.values())
        link = self.link.next_deadline()
        if link is not None:
            times.append(link)
        event = self.model.next_event()
        if event is not None and self._last_now is not None:
            ahead = max(0.0, event - self.model.clock) / self.config.speedup
            times.append(self._last_now + ahead)
        return min(times, default=None)

    # -- time ------------------------------------------------------------------------------------
    def _advance(self, now: float) -> None:
        if self._last_now is None:
            self._last_now = now
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

    def _settle(self, now: float) -> None:
        """After every call: forget watchdogs of stopped jogs, send a second answer that is
        due, and save what changed."""
        for channel in list(self._jog_deadlines):
            if self.model.channel(channel).jog is None:
                del self._jog_deadlines[channel]
        second = self._second
        if second is not None and second.timer.done and self.link.state is State.WORKING:
            self._second = None
            packet = second.packet
            if second.timer.failure is not None:
                packet = self._refuse(second.command, second.timer.failure)
            self._send(now, [packet], After.DONE)
        self._persist()

    # -- link events -----------------------------------------------------------------------------
    def _dispatch(self, events: list[LinkEvent], now: float) -> None:
        for event in events:
            if isinstance(event, RequestReceived):
                self._request(event.data, now)
            elif isinstance(event, UploadPacketReceived):
                self._upload_packet(event, now)
            elif isinstance(event, ExchangeFailed):
                self._second = None
                self._upload = None
                if event.reason is not FailReason.SUPERSEDED:
                    self._error(f"exchange dropped ({event.reason.value}): {event.detail}")

    def _request(self, data: bytes, now: float) -> None:
        self.requests += 1
        self._second = None
        self._upload = None
        try:
            command = decode_request(data)
        except FieldError as exc:
            self._error(str(exc))
            self._send(now, [_error_answer(data, exc.flag)], After.DONE)
            return
        try:
            outcome = handle(self.model, command)
        except Refused as exc:
            self._send(now, [self._refuse(command, exc)], After.DONE)
            return
        if command.CHANGES_STATE and not isinstance(outcome, Upload):
            self.executions[command.CODE] += 1
        if isinstance(outcome, Reply):
            self._reply(command, outcome, now)
        elif isinstance(outcome, Deferred):
            self._defer(command, outcome, now)
        else:
            self._upload = _UploadSession(command, outcome)
            self._send(now, [command.ok()], After.UPLOAD)

    def _reply(self, command: Command[Any], reply: Reply, now: float) -> None:
        try:
            packets = command.encode_answer(reply.result)
        except FieldError as exc:
            # The state holds something the answer's fields cannot carry.
            packets = [self._refuse(command, Refused(str(exc)))]
        if isinstance(command, JogStart | JogContinue):
            self._jog_deadlines[command.channel] = now + JOG_WATCHDOG
        self._send(now, packets, After.DONE)

    def _defer(self, command: Command[Any], deferred: Deferred, now: float) -> None:
        timer = self.model.schedule(deferred.duration, deferred.finish)
        self.model.advance(0.0)  # work that takes no time is done at once
        if deferred.wait is None:
            packets = command.encode_answer(None)
        else:
            real = deferred.duration / self.config.speedup
            packets = command.encode_answer(min(deferred.wait, math.ceil(real)))
        self._second = _SecondPhase(command, timer, packets[1])
        self._send(now, [packets[0]], After.SECOND_PHASE)

    def _upload_packet(self, event: UploadPacketReceived, now: float) -> None:
        session = self._upload
        if session is None:  # the link only reports these inside an FB exchange
            return
        command = session.command
        target = session.target
        if event.end:
            self._upload = None
            self.model.store_upload(
                target.channel, target.file, target.job_number, session.lines, session.points
            )
            self.executions[command.CODE] += 1
            self._persist()
            self._dispatch(self.link.accept_upload(now), now)
            return
        try:
            line = UploadFile.decode_line(event.data)
            if target.file.is_points:
                number, point = parse_point_line(
                    line, command="FB", field=f"line {len(session.lines) + 1}"
                )
                if number in session.points:
                    raise FieldError("FB", "line", f"point P{number:04d} is repeated")
                session.points[number] = point
        except FieldError as exc:
            self._upload = None
            self._error(str(exc))
            self._send(now, [command.error_answer(exc.flag)], After.FINAL)
            return
        session.lines.append(line)
        self._send(now, [command.ok()], After.UPLOAD)

    # -- answers -----------------------------------------------------------------------------
    def _refuse(self, command: Command[Any], refusal: Refused) -> bytes:
        self._error(refusal.reason)
        return command.error_answer(refusal.flag)

    def _error(self, text: str) -> None:
        """Keep ``text`` for KD, as one packet can carry it: printable ASCII, 245 bytes."""
        clean = "".join(c if " " <= c <= "~" else "?" for c in text)
        self.model.last_error = clean[:MAX_TEXT]

    def _send(self, now: float, packets: list[bytes], after: After) -> None:
        self._persist()
        self._dispatch(self.link.send_answer(packets, after, now), now)

    def _persist(self) -> None:
        if self._store is not None and self.model.revision != self._saved:
            self._store.save(self.model.snapshot())
            self._saved = self.model.revision


def _error_answer(data: bytes, flag: int) -> bytes:
    """An error answer to a request that did not decode, with its command's dummy convention."""
    code = data[1:3].decode("ascii", "replace")
    dummy = any(cls.ANSWER_DUMMY for cls in COMMANDS.get(code, ()))
    if flag not in (FLAG_REJECTED, FLAG_FAILED, FLAG_UNSUPPORTED):
        flag = FLAG_REJECTED
    return make_answer(flag, dummy=dummy)
