"""One N1 session in the controller role, sans-IO: the link, request decoding, FB assembly.

A :class:`ControllerSession` is driven like a :class:`~robostar.transport.peer.BytePeer` (bytes and
the time in, bytes out) and hands each decoded request to a :class:`Backend` as a :class:`Request`.
The backend answers it at once or later, from anywhere on the session's thread or event loop; a late
answer is applied on the next call into the session (the session calls its ``on_ready`` hook so that
the host makes that call soon). Every piece of work runs from one loop, never recursively, so any
number of requests in one write cannot exhaust the stack.
"""

from __future__ import annotations

import enum
import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from robostar.commands import COMMANDS, decode_request
from robostar.commands.base import Command
from robostar.commands.files import UploadFile, parse_point_line
from robostar.commands.system import MAX_TEXT
from robostar.errors import FieldError, UsageError
from robostar.protocol.fields import FLAG_FAILED, FLAG_REJECTED, FLAG_UNSUPPORTED
from robostar.protocol.frame import CorruptReason
from robostar.protocol.link import (
    After,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    LinkEvent,
    PeerMovedOn,
    RequestReceived,
    State,
    UploadPacketReceived,
)
from robostar.protocol.packets import Shape, make_answer
from robostar.types import Point

__all__ = ["Backend", "ControllerSession", "Refusal", "Request", "UploadLimits"]

log = logging.getLogger(__name__)

_CORRUPT_TEXT = {
    CorruptReason.BAD_LRC: "LRC is different with received data LRC",
    CorruptReason.TOO_LONG: "packet is longer than 250 bytes",
    CorruptReason.TRUNCATED: "packet was cut short by a new STX",
}
_REFUSAL_FLAGS = (FLAG_REJECTED, FLAG_FAILED, FLAG_UNSUPPORTED)


class Refusal(Exception):
    """A request the backend will not carry out: the answer ``flag`` (0x31/0x32/0x33) and the
    ``reason`` KD reports."""

    def __init__(self, reason: str, flag: int = FLAG_FAILED) -> None:
        if flag not in _REFUSAL_FLAGS:
            raise UsageError(f"flag: {flag:#04x} is not 0x31, 0x32 or 0x33")
        self.flag = flag
        self.reason = reason
        super().__init__(reason)


@dataclass(frozen=True, slots=True)
class UploadLimits:
    """What one FB upload may hold; past it the upload is refused with 0x32 and a KD reason.

    The defaults are above what an N1 holds in one file (a 2000-step job, 1024 global points
    and a point file of the same order) and far below what would strain the server."""

    max_lines: int = 4000
    max_bytes: int = 512 * 1024


class _Phase(enum.Enum):
    WAITING = "waiting for the backend"
    SECOND = "waiting for the second answer"
    DONE = "answered"


class Request:
    """One request of one session, handed to :meth:`Backend.handle`.

    Answer exactly once with :meth:`answer` (the command's result, encoded by its
    ``encode_answer``) or :meth:`refuse`. A two-phase command (DB, DC, CE) answered with
    :meth:`answer` gets its first packet now and its second when the backend calls
    :meth:`finish` (or :meth:`refuse`, which turns the second answer into an error). The answer
    always goes to the session that asked; after that session's exchange ended (the host moved
    on, the connection closed) :attr:`live` is False and answers are dropped. When no answer
    would be true, :meth:`abort` ends the exchange with RST instead.
    """

    __slots__ = ("_abort", "_packets", "_phase", "_refusal", "_session", "command", "points")

    def __init__(self, session: ControllerSession, command: Command[Any]) -> None:
        self._session = session
        self.command = command
        self.points: dict[int, Point] = {}
        """FB to a point file: the points of the upload's lines, by number."""
        self._phase = _Phase.WAITING
        self._packets: list[bytes] | None = None
        self._refusal: Refusal | None = None
        self._abort: str | None = None

    @property
    def session(self) -> ControllerSession:
        return self._session

    @property
    def live(self) -> bool:
        """The session still waits for this request's answer."""
        return self._session.current is self and self._phase is not _Phase.DONE

    @property
    def two_phase(self) -> bool:
        return self.command.SHAPE is Shape.TWO_PHASE

    def answer(self, result: Any = None) -> None:
        """Answer with ``result`` (for FB: None; for DB/DC: the expected wait)."""
        if (
            self._phase is not _Phase.WAITING
            or self._packets is not None
            or self._abort is not None
        ):
            raise UsageError(f"answer: {self.command.CODE} is already answered")
        if isinstance(self.command, UploadFile):
            self._packets = []
        else:
            packets = self.command.encode_answer(result)
            self._packets = self._session.backend.dress_answer(self.command, packets)
        self._session._answered(self)

    def finish(self) -> None:
        """Two-phase: the work is done; send the second answer."""
        if not self.two_phase or self._packets is None:
            raise UsageError(f"finish: {self.command.CODE} has no first answer to follow")
        self._session._answered(self)

    def refuse(self, reason: str, flag: int = FLAG_FAILED) -> None:
        """Refuse (or, in the second phase, fail) with ``flag``; ``reason`` becomes KD's text."""
        self._refusal = Refusal(reason, flag)
        self._session._answered(self)

    def abort(self, reason: str) -> None:
        """End the exchange with RST, as a controller that cannot answer does; ``reason``
        becomes KD's text.

        For a request whose outcome the backend cannot tell (a state change that may have run):
        a failure flag would tell the host that nothing happened, and a host that retries on
        failure would run it twice; after an RST its link reports the outcome unknown. As any
        answer it goes out on the session's next turn (``on_ready`` asks for one), and not at
        all once :attr:`live` is False. The session then drops the request as it drops any
        exchange the link gave up."""
        self._abort = reason or "exchange aborted"
        self._session._answered(self)


class Backend:
    """What a session hands its requests to. Override :meth:`handle`; the rest are hooks."""

    def handle(self, request: Request) -> None:
        """Act on ``request`` and answer it now or later (raising :class:`Refusal` refuses)."""
        raise NotImplementedError

    def begin_upload(self, session: ControllerSession, command: UploadFile) -> None:
        """FB arrived in ``session`` (no lines yet): raise :class:`Refusal` to refuse before the
        lines (the session says who uploads: one backend serves many)."""

    def exchange_abandoned(self, session: ControllerSession, request: Request) -> None:
        """The host of ``session`` gave ``request``'s exchange up (an RST, a new request) while
        the backend still has it: stop work nobody waits for (a write queued for a host that
        moved on must not run). Told at once (the link holds the host's input until the
        answer), once a request. The request stays :attr:`~Request.live` until the backend
        answers it (the answer is then not sent): only that lets the session take the host's
        next request. After a two-phase first answer the host's move ends the exchange at once
        instead, and :attr:`~Request.live` turns False."""

    def note_error(self, session: ControllerSession, text: str) -> None:
        """A refusal or a line error in ``session``: the text KD is to report."""

    def session_closed(self, session: ControllerSession) -> None:
        """``session``'s connection is gone (release what it held)."""

    def dress_answer(self, command: Command[Any], packets: list[bytes]) -> list[bytes]:
        """The answer packets as they go on the wire (a simulator's dialect rewrites them)."""
        return packets


@dataclass
class _Upload:
    request: Request
    lines: list[str]
    size: int = 0


class ControllerSession:
    """An N1 session (controller role) for one connection, serving ``backend``."""

    def __init__(
        self,
        backend: Backend,
        *,
        timeout: float = 2.0,
        limits: UploadLimits | None = None,
        name: str = "n1",
    ) -> None:
        self.backend = backend
        self.name = name
        self.limits = limits or UploadLimits()
        self.link = ControllerLink(timeout=timeout)
        self.requests = 0
        """Request packets received."""
        self.last_error = ""
        """The last refusal or line error, as KD reports it."""
        self.on_ready: Callable[[], None] | None = None
        """Called when a late answer is ready: the host should call :meth:`output`."""
        self.closed = False
        self.current: Request | None = None
        self._upload: _Upload | None = None
        self._events: deque[LinkEvent] = deque()
        self._ready: deque[Request] = deque()
        self._now = 0.0
        self._running = False

    # -- BytePeer ------------------------------------------------------------------------------
    def feed(self, data: bytes, now: float) -> None:
        """Bytes the host program wrote (ignored once closed)."""
        if self.closed:
            return
        self._now = now
        corrupt_before = self.link.corrupt_frames
        events = self.link.receive_data(data, now)
        if self.link.corrupt_frames != corrupt_before and self.link.last_corrupt is not None:
            self.error(_CORRUPT_TEXT[self.link.last_corrupt])
        self._run(events)

    def output(self, now: float) -> bytes:
        """Apply ready answers and timeouts at ``now``; the bytes for the host program."""
        self._now = now
        self._run(self.link.handle_timeout(now))
        return self.link.data_to_send()

    def next_deadline(self) -> float | None:
        return self.link.next_deadline()

    def close(self) -> None:
        """The connection is gone: drop the open exchange and tell the backend."""
        if self.closed:
            return
        self.closed = True
        self.current = None
        self._upload = None
        self._ready.clear()
        self.backend.session_closed(self)

    def error(self, text: str) -> None:
        """Keep ``text`` for KD as one packet can carry it (printable ASCII, 245 bytes)."""
        clean = "".join(c if " " <= c <= "~" else "?" for c in text)[:MAX_TEXT]
        self.last_error = clean
        self.backend.note_error(self, clean)

    # -- the loop ------------------------------------------------------------------------------
    def _answered(self, request: Request) -> None:
        if request._session is not self or self.closed:
            return
        self._ready.append(request)
        if not self._running and self.on_ready is not None:
            self.on_ready()

    def _run(self, events: list[LinkEvent]) -> None:
        """Handle link events and ready answers until none is left (one loop, no recursion)."""
        self._events.extend(events)
        if self._running:
            return
        self._running = True
        try:
            while True:
                if self._events:
                    self._on_event(self._events.popleft())
                elif not self._apply_ready():
                    break
        finally:
            self._running = False

    def _on_event(self, event: LinkEvent) -> None:
        if isinstance(event, RequestReceived):
            self._request(event.data)
        elif isinstance(event, UploadPacketReceived):
            self._upload_packet(event)
        elif isinstance(event, ExchangeComplete):
            if self.current is not None and self.current._phase is _Phase.DONE:
                self.current = None
        elif isinstance(event, ExchangeFailed):
            self._drop_exchange()
            if event.reason is not FailReason.SUPERSEDED:
                self.error(f"exchange dropped ({event.reason.value}): {event.detail}")
        elif isinstance(event, PeerMovedOn):
            request = self.current
            if request is not None and request.live:
                self.backend.exchange_abandoned(self, request)

    def _drop_exchange(self) -> None:
        """The exchange ended abnormally: its request and upload are over."""
        self.current = None
        self._upload = None

    def _apply_ready(self) -> bool:
        """Apply the first ready answer that can go out now; False when none can."""
        for _ in range(len(self._ready)):
            request = self._ready.popleft()
            if request is not self.current or request._phase is _Phase.DONE:
                continue  # stale: the exchange it belonged to is over
            if (
                request._phase is _Phase.SECOND
                and request._abort is None  # an abort ends the exchange in any state
                and self.link.state is not State.WORKING
            ):
                if self.link.state is State.WAIT_ACK:
                    self._ready.append(request)  # the first answer is not ACKed yet
                continue
            self._apply(request)
            return True
        return False

    def _apply(self, request: Request) -> None:
        command = request.command
        refusal = request._refusal
        if request._abort is not None:
            request._phase = _Phase.DONE
            self._abort_exchange(request._abort)
        elif refusal is not None:
            request._phase = _Phase.DONE
            self.error(refusal.reason)
            after = After.FINAL if isinstance(command, UploadFile) else After.DONE
            self._send([command.error_answer(refusal.flag)], after)
        elif isinstance(command, UploadFile):
            request._phase = _Phase.DONE
            self._events.extend(self.link.accept_upload(self._now))
        elif request._phase is _Phase.SECOND:
            assert request._packets is not None
            request._phase = _Phase.DONE
            self._send(request._packets[1:], After.DONE)
        else:
            assert request._packets is not None
            if request.two_phase:
                request._phase = _Phase.SECOND
                self._send(request._packets[:1], After.SECOND_PHASE)
            else:
                request._phase = _Phase.DONE
                self._send(request._packets, After.DONE)

    def _abort_exchange(self, reason: str) -> None:
        """RST: the link reports the exchange failed (ABORTED), then takes any input it held.
        The exchange is dropped as any other the link gave up, but KD says the backend's reason
        rather than the link's "aborted by the application"."""
        events = self.link.abort(self._now)
        self._drop_exchange()
        self.error(reason)
        self._events.extend(
            event
            for event in events
            if not (isinstance(event, ExchangeFailed) and event.reason is FailReason.ABORTED)
        )

    def _send(self, packets: list[bytes], after: After) -> None:
        self._events.extend(self.link.send_answer(packets, after, self._now))

    # -- requests ------------------------------------------------------------------------------
    def _request(self, data: bytes) -> None:
        self.requests += 1
        self.current = None
        self._upload = None
        try:
            command = decode_request(data)
        except FieldError as exc:
            self.error(str(exc))
            self._send([_error_answer(data, exc.flag)], After.DONE)
            return
        request = Request(self, command)
        self.current = request
        try:
            if isinstance(command, UploadFile):
                self.backend.begin_upload(self, command)
                self._upload = _Upload(request, [])
                self._send([command.ok()], After.UPLOAD)
            else:
                self.backend.handle(request)
        except Refusal as refusal:
            if request._phase is _Phase.WAITING and request._packets is None:
                request.refuse(refusal.reason, refusal.flag)

    def _upload_packet(self, event: UploadPacketReceived) -> None:
        upload = self._upload
        if upload is None:  # the link only reports these inside an FB exchange
            return
        request = upload.request
        command = request.command
        assert isinstance(command, UploadFile)
        if event.end:
            self._upload = None
            request.command = UploadFile(
                command.channel, command.file, command.job_number, upload.lines
            )
            try:
                self.backend.handle(request)
            except Refusal as refusal:
                if request._phase is _Phase.WAITING and request._packets is None:
                    request.refuse(refusal.reason, refusal.flag)
            return
        try:
            line = self._take_line(upload, event.data)
        except FieldError as exc:
            self._upload = None
            request._phase = _Phase.DONE
            self.error(str(exc))
            self._send([command.error_answer(exc.flag)], After.FINAL)
            return
        upload.lines.append(line)
        self._send([command.ok()], After.UPLOAD)

    def _take_line(self, upload: _Upload, body: bytes) -> str:
        number = len(upload.lines) + 1
        if number > self.limits.max_lines:
            raise FieldError(
                "FB",
                "lines",
                f"more than {self.limits.max_lines} lines in one upload",
                flag=FLAG_FAILED,
            )
        upload.size += len(body)
        if upload.size > self.limits.max_bytes:
            raise FieldError(
                "FB",
                "size",
                f"more than {self.limits.max_bytes} bytes in one upload",
                flag=FLAG_FAILED,
            )
        line = UploadFile.decode_line(body)
        request = upload.request
        command = request.command
        assert isinstance(command, UploadFile)
        if command.file.is_points:
            point_number, point = parse_point_line(line, command="FB", field=f"line {number}")
            if point_number in request.points:
                raise FieldError("FB", "line", f"point P{point_number:04d} is repeated")
            request.points[point_number] = point
        return line


def _error_answer(data: bytes, flag: int) -> bytes:
    """An error answer to a request that did not decode, with its command's dummy convention."""
    code = data[1:3].decode("ascii", "replace")
    dummy = any(cls.ANSWER_DUMMY for cls in COMMANDS.get(code, ()))
    if flag not in _REFUSAL_FLAGS:
        flag = FLAG_REJECTED
    return make_answer(flag, dummy=dummy)
