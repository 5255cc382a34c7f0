"""The link layer (ACK/NAK/RST, resends, timeouts) as one transition table, for both roles.

No I/O and no clock: the driver feeds bytes with :meth:`Link.receive_data`, takes bytes to write
from :meth:`Link.data_to_send`, asks :meth:`Link.next_deadline` when to call
:meth:`Link.handle_timeout`, and passes the current time (any monotonic seconds) into every call.
Each call returns the events it produced.

Every allowed ``(state, input)`` pair is in :data:`TRANSITIONS`; a pair that is not there is a
rule broken by the peer (the link sends RST and reports :class:`ExchangeFailed` with a
:class:`~robostar.errors.LinkRuleError`) or, for an app call, raised as LinkRuleError at once.
``docs/protocol.md`` draws the table.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import ClassVar

from robostar.errors import LinkRuleError, UsageError
from robostar.protocol.fields import FLAG_END, FLAG_OK
from robostar.protocol.frame import (
    ACK,
    MAX_PACKET,
    NAK,
    RST,
    Control,
    ControlKind,
    CorruptPacket,
    CorruptReason,
    FrameDecoder,
    FrameEvent,
    Packet,
    encode_packet,
    lone_frame,
)
from robostar.protocol.packets import Shape, split_answer

__all__ = [
    "EARLY_CODES",
    "STOP_CODES",
    "TRANSITIONS",
    "After",
    "AnswerReceived",
    "ControllerLink",
    "ExchangeComplete",
    "ExchangeFailed",
    "FailReason",
    "Fence",
    "HostLink",
    "Ignored",
    "Input",
    "Link",
    "LinkEvent",
    "PeerMovedOn",
    "RequestReceived",
    "Role",
    "State",
    "UploadPacketReceived",
    "UploadReady",
    "announced_wait",
]

MAX_NAKS = 3
"""NAKs in a row for one packet before RST (the receiver's 4th refusal is RST)."""
MAX_RESENDS = 3
"""Resends of an unacknowledged answer by the controller before it drops the exchange."""
MAX_ANNOUNCED_WAIT = 99.0
"""The longest work time a two-phase first answer can announce: its field is two digits."""
MAX_MULTI_PACKETS = 10_002
"""Packets a multi-packet answer may take when the request does not say (a 9999-step job with
its announcement and END); past it the answer is cut with RST."""
STOP_CODES = frozenset((b"CF", b"CD", b"CI", b"BG"))
"""The stops (CF emergency stop, CD job stop, CI homing stop, BG jog stop; the line server's
``STOPS``). Each answers a bare flag."""
EARLY_CODES = STOP_CODES | {b"BF"}
"""The only requests let out ``abort_gap`` after this end's own abort, before the whole quiet
gap: the stops, and a running jog's keepalive (BF), which the controller needs within 500 ms
or it stops the jog itself; like the stops it answers a bare flag."""
MAX_BACKLOG = 64
"""Frames held for an application that has its turn when more arrive (requests pipelined
behind the one being handled); more are dropped and counted in ``overrun_frames``."""


class Role(enum.Enum):
    HOST = "host"
    CONTROLLER = "controller"

    # Members are singletons compared by identity: hash them so too (in C), not by name in
    # Python (Enum.__hash__), since every dispatch looks one up.
    __hash__ = object.__hash__


class State(enum.Enum):
    # host
    IDLE = "IDLE"
    WAIT_ANSWER = "WAIT_ANSWER"
    WAIT_MORE = "WAIT_MORE"
    WAIT_SECOND = "WAIT_SECOND"
    WAIT_FENCE = "WAIT_FENCE"
    UPLOAD_WAIT_REPLY = "UPLOAD_WAIT_REPLY"
    UPLOAD_READY = "UPLOAD_READY"
    UPLOAD_WAIT_ACK = "UPLOAD_WAIT_ACK"
    RESYNC = "RESYNC"
    # controller
    LISTEN = "LISTEN"
    HANDLING = "HANDLING"
    WAIT_ACK = "WAIT_ACK"
    WORKING = "WORKING"
    UPLOAD_WAIT_PACKET = "UPLOAD_WAIT_PACKET"
    UPLOAD_HANDLING = "UPLOAD_HANDLING"

    __hash__ = object.__hash__  # identity, as Role's


class Input(enum.Enum):
    # from the line
    PACKET = "packet"
    CORRUPT = "corrupt packet"
    ACK = "ACK"
    NAK = "NAK"
    RST = "RST"
    TIMEOUT = "timeout"
    # from the application
    SEND_REQUEST = "send_request"
    SEND_LINE = "send_upload_line"
    SEND_END = "send_upload_end"
    SEND_ANSWER = "send_answer"
    ACCEPT_UPLOAD = "accept_upload"
    ABORT = "abort"

    __hash__ = object.__hash__  # identity, as Role's


_APP_INPUTS = frozenset(
    (
        Input.SEND_REQUEST,
        Input.SEND_LINE,
        Input.SEND_END,
        Input.SEND_ANSWER,
        Input.ACCEPT_UPLOAD,
        Input.ABORT,
    )
)


class After(enum.Enum):
    """What a controller expects after the answer packets it sends."""

    DONE = "done"
    """Each packet is ACKed; after the last, the exchange is complete."""
    SECOND_PHASE = "second phase"
    """Each packet is ACKed; then the application sends the second answer (DB, DC, CE)."""
    UPLOAD = "upload"
    """FB: no ACK; the host's next upload packet follows."""
    FINAL = "final"
    """No ACK; the exchange ends at once (an FB error reply)."""


class FailReason(enum.Enum):
    TIMEOUT = "timeout"
    RESET = "reset by peer"
    NAK_LIMIT = "NAK limit"
    RULE = "rule broken"
    ABORTED = "aborted"
    SUPERSEDED = "superseded by a new request"
    TOO_LONG = "answer longer than the command can carry"


# -- events ---------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class AnswerReceived:
    """Host: an answer packet of the current exchange (already ACKed where the rules say)."""

    data: bytes
    flag: int
    final: bool


@dataclass(frozen=True, slots=True)
class UploadReady:
    """Host, FB: the controller accepted the last packet; send the next line or the end."""

    data: bytes


@dataclass(frozen=True, slots=True)
class ExchangeComplete:
    """The exchange ended as the rules say (error flags included)."""


@dataclass(frozen=True, slots=True)
class ExchangeFailed:
    """The exchange ended abnormally; ``error`` is set for a rule break."""

    reason: FailReason
    state: State
    detail: str = ""
    error: LinkRuleError | None = None


@dataclass(frozen=True, slots=True)
class RequestReceived:
    """Controller: a request packet; answer it with :meth:`ControllerLink.send_answer`."""

    data: bytes


@dataclass(frozen=True, slots=True)
class UploadPacketReceived:
    """Controller, FB: a content packet (``end`` False) or the closing 0x34 (``end`` True)."""

    data: bytes
    end: bool


@dataclass(frozen=True, slots=True)
class PeerMovedOn:
    """Controller, in the application's turn (:data:`APP_TURN`): a read brought an RST or a
    packet, so the host has given the exchange up while the application still works on it.

    The input is held as any input in the turn, and the application's answer will not be sent
    (``Link._peer_moved_on``); this says so at once, so that the application can drop work
    nobody waits for any more. Reported once a turn, for input read after the turn began (what
    came in the same read as the request that started it is taken in order after the answer,
    as ever)."""

    state: State


@dataclass(frozen=True, slots=True)
class Ignored:
    """Something arrived that the rules say to drop (a stray ACK, a resent packet); for traces."""

    what: str
    state: State


@dataclass(frozen=True, slots=True)
class Fence:
    """A read the host sends before its next request after an abandoned exchange, whose
    answer no other request's answer can be taken for (``accepts``). Whatever arrives before
    that answer belongs to an exchange the host gave up, and is dropped; after it, the line
    holds nothing old (the controller answers in order), and the request goes out."""

    request: bytes
    """The read's packet data, ``FF G1 G2 params``."""
    accepts: Callable[[bytes], bool]
    """True for an answer packet (flag 0x30) that only this read can have."""

    @property
    def code(self) -> bytes:
        return self.request[1:3]


LinkEvent = (
    AnswerReceived
    | UploadReady
    | ExchangeComplete
    | ExchangeFailed
    | RequestReceived
    | UploadPacketReceived
    | PeerMovedOn
    | Ignored
)

_Handler = Callable[["Link", bytes], None]

_H = Role.HOST
_C = Role.CONTROLLER

TRANSITIONS: dict[tuple[Role, State, Input], str] = {
    # ---- host ----------------------------------------------------------------------------
    (_H, State.IDLE, Input.SEND_REQUEST): "_h_send_request",
    (_H, State.IDLE, Input.PACKET): "_h_stray_packet",
    (_H, State.IDLE, Input.CORRUPT): "_ignore",
    (_H, State.IDLE, Input.ACK): "_ignore",
    (_H, State.IDLE, Input.NAK): "_ignore",
    (_H, State.IDLE, Input.RST): "_ignore",
    (_H, State.IDLE, Input.ABORT): "_ignore",
    (_H, State.WAIT_ANSWER, Input.PACKET): "_h_answer",
    (_H, State.WAIT_ANSWER, Input.CORRUPT): "_nak_corrupt",
    (_H, State.WAIT_ANSWER, Input.NAK): "_resend",
    (_H, State.WAIT_ANSWER, Input.ACK): "_ignore",
    (_H, State.WAIT_ANSWER, Input.RST): "_reset_by_peer",
    (_H, State.WAIT_ANSWER, Input.TIMEOUT): "_h_timeout",
    (_H, State.WAIT_ANSWER, Input.ABORT): "_abort",
    (_H, State.WAIT_MORE, Input.PACKET): "_h_answer",
    (_H, State.WAIT_MORE, Input.CORRUPT): "_nak_corrupt",
    (_H, State.WAIT_MORE, Input.ACK): "_ignore",
    (_H, State.WAIT_MORE, Input.NAK): "_ignore",
    (_H, State.WAIT_MORE, Input.RST): "_reset_by_peer",
    (_H, State.WAIT_MORE, Input.TIMEOUT): "_h_timeout",
    (_H, State.WAIT_MORE, Input.ABORT): "_abort",
    (_H, State.WAIT_SECOND, Input.PACKET): "_h_answer",
    (_H, State.WAIT_SECOND, Input.CORRUPT): "_nak_corrupt",
    (_H, State.WAIT_SECOND, Input.ACK): "_ignore",
    (_H, State.WAIT_SECOND, Input.NAK): "_ignore",
    (_H, State.WAIT_SECOND, Input.RST): "_reset_by_peer",
    (_H, State.WAIT_SECOND, Input.TIMEOUT): "_h_timeout",
    (_H, State.WAIT_SECOND, Input.ABORT): "_abort",
    (_H, State.WAIT_FENCE, Input.PACKET): "_h_fence_answer",
    (_H, State.WAIT_FENCE, Input.CORRUPT): "_nak_corrupt",
    (_H, State.WAIT_FENCE, Input.NAK): "_resend",
    (_H, State.WAIT_FENCE, Input.ACK): "_ignore",
    (_H, State.WAIT_FENCE, Input.RST): "_reset_by_peer",
    (_H, State.WAIT_FENCE, Input.TIMEOUT): "_h_timeout",
    (_H, State.WAIT_FENCE, Input.ABORT): "_abort",
    (_H, State.UPLOAD_WAIT_REPLY, Input.PACKET): "_h_upload_reply",
    (_H, State.UPLOAD_WAIT_REPLY, Input.CORRUPT): "_nak_corrupt",
    (_H, State.UPLOAD_WAIT_REPLY, Input.NAK): "_resend",
    (_H, State.UPLOAD_WAIT_REPLY, Input.ACK): "_ignore",
    (_H, State.UPLOAD_WAIT_REPLY, Input.RST): "_reset_by_peer",
    (_H, State.UPLOAD_WAIT_REPLY, Input.TIMEOUT): "_h_timeout",
    (_H, State.UPLOAD_WAIT_REPLY, Input.ABORT): "_abort",
    (_H, State.UPLOAD_READY, Input.SEND_LINE): "_h_send_line",
    (_H, State.UPLOAD_READY, Input.SEND_END): "_h_send_end",
    (_H, State.UPLOAD_READY, Input.ABORT): "_abort",
    (_H, State.UPLOAD_WAIT_ACK, Input.ACK): "_h_upload_done",
    (_H, State.UPLOAD_WAIT_ACK, Input.PACKET): "_h_upload_final_reply",
    (_H, State.UPLOAD_WAIT_ACK, Input.CORRUPT): "_nak_corrupt",
    (_H, State.UPLOAD_WAIT_ACK, Input.NAK): "_resend",
    (_H, State.UPLOAD_WAIT_ACK, Input.RST): "_reset_by_peer",
    (_H, State.UPLOAD_WAIT_ACK, Input.TIMEOUT): "_h_timeout",
    (_H, State.UPLOAD_WAIT_ACK, Input.ABORT): "_abort",
    (_H, State.RESYNC, Input.SEND_REQUEST): "_h_defer_request",
    (_H, State.RESYNC, Input.PACKET): "_h_resync_packet",
    (_H, State.RESYNC, Input.CORRUPT): "_h_resync_noise",
    (_H, State.RESYNC, Input.ACK): "_ignore",
    (_H, State.RESYNC, Input.NAK): "_ignore",
    (_H, State.RESYNC, Input.RST): "_ignore",
    (_H, State.RESYNC, Input.ABORT): "_h_drop_deferred",
    (_H, State.RESYNC, Input.TIMEOUT): "_h_resync_done",
    # ---- controller ----------------------------------------------------------------------
    (_C, State.LISTEN, Input.PACKET): "_c_request",
    (_C, State.LISTEN, Input.CORRUPT): "_nak_corrupt",
    (_C, State.LISTEN, Input.ACK): "_ignore",
    (_C, State.LISTEN, Input.NAK): "_ignore",
    (_C, State.LISTEN, Input.RST): "_ignore",
    (_C, State.LISTEN, Input.ABORT): "_ignore",
    (_C, State.HANDLING, Input.SEND_ANSWER): "_c_send_answer",
    (_C, State.HANDLING, Input.ABORT): "_abort",
    (_C, State.WAIT_ACK, Input.ACK): "_c_acked",
    (_C, State.WAIT_ACK, Input.NAK): "_resend",
    (_C, State.WAIT_ACK, Input.TIMEOUT): "_c_ack_timeout",
    (_C, State.WAIT_ACK, Input.PACKET): "_c_superseded",
    (_C, State.WAIT_ACK, Input.CORRUPT): "_nak_corrupt",
    (_C, State.WAIT_ACK, Input.RST): "_reset_by_peer",
    (_C, State.WAIT_ACK, Input.ABORT): "_abort",
    (_C, State.WORKING, Input.SEND_ANSWER): "_c_send_answer",
    (_C, State.WORKING, Input.PACKET): "_c_superseded",
    (_C, State.WORKING, Input.CORRUPT): "_nak_corrupt",
    (_C, State.WORKING, Input.ACK): "_ignore",
    (_C, State.WORKING, Input.NAK): "_ignore",
    (_C, State.WORKING, Input.RST): "_reset_by_peer",
    (_C, State.WORKING, Input.ABORT): "_abort",
    (_C, State.UPLOAD_WAIT_PACKET, Input.PACKET): "_c_upload_packet",
    (_C, State.UPLOAD_WAIT_PACKET, Input.CORRUPT): "_nak_corrupt",
    (_C, State.UPLOAD_WAIT_PACKET, Input.NAK): "_resend",
    (_C, State.UPLOAD_WAIT_PACKET, Input.ACK): "_ignore",
    (_C, State.UPLOAD_WAIT_PACKET, Input.TIMEOUT): "_c_upload_timeout",
    (_C, State.UPLOAD_WAIT_PACKET, Input.RST): "_reset_by_peer",
    (_C, State.UPLOAD_WAIT_PACKET, Input.ABORT): "_abort",
    (_C, State.UPLOAD_HANDLING, Input.SEND_ANSWER): "_c_send_answer",
    (_C, State.UPLOAD_HANDLING, Input.ACCEPT_UPLOAD): "_c_accept_upload",
    (_C, State.UPLOAD_HANDLING, Input.ABORT): "_abort",
}
"""Every allowed (role, state, input) and its handler; anything else breaks a rule.

Line input never reaches the application's-turn states (:data:`APP_TURN`): it waits there."""

APP_TURN = frozenset((State.HANDLING, State.UPLOAD_HANDLING, State.UPLOAD_READY))
"""States where the application holds the exchange (it must answer, or send the next upload
packet). Bytes that arrive meanwhile — even in the same read as the request — are held and
taken in order once the application has acted, as h11 pauses while a request is served: an RST
or a second request right behind a request must not pull the exchange from under the answer.
If the held input shows that the peer moved on (an RST, a new request, any packet), the
application's packet is not sent at all (see ``Link._peer_moved_on``)."""

_RESEND_SHARE = 0.9
"""An answer equal to the last one ACKed is the controller resending it (its ACK lost) only
from this share of the controller's resend timeout on; sooner, it is new data."""

_NOT_BUSY = frozenset((State.IDLE, State.RESYNC))
"""A host link's states outside an exchange (:attr:`Link.busy` is False in them)."""

_COMPLETE = ExchangeComplete()
"""ExchangeComplete has no fields: every one equals every other, so one will do."""

_CONTROL_INPUT = {
    ControlKind.ACK: Input.ACK,
    ControlKind.NAK: Input.NAK,
    ControlKind.RST: Input.RST,
}
_ERROR_FLAGS = frozenset((0x31, 0x32, 0x33))


class Link:
    """The link state machine for one end of the line. Use :class:`HostLink` or
    :class:`ControllerLink`."""

    role: Role
    _idle: State
    _handlers: ClassVar[dict[tuple[State, Input], _Handler]] = {}
    """This class's rows of :data:`TRANSITIONS`, each with its handler function (made once per
    class, so that a dispatch is one dictionary lookup)."""

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        role = getattr(cls, "role", None)
        if role is not None:
            cls._handlers = {
                (state, what): getattr(cls, name)
                for (row_role, state, what), name in TRANSITIONS.items()
                if row_role is role
            }

    def __init__(self, *, timeout: float = 2.0, resend_gap: float = 0.25):
        self.timeout = timeout
        """Reply timeout (host) / ACK timeout (controller), seconds."""
        self.resend_gap = resend_gap
        """Host: a packet equal to the one just ACKed, arriving at least this long after our
        ACK, is the controller resending it (our ACK was lost), not new data."""
        self.state = self._idle
        self.decoder = FrameDecoder()
        self._out = bytearray()
        self._events: list[LinkEvent] = []
        self._deadline: float | None = None
        self._now = 0.0
        self._last_sent = b""  # framed, for resends
        self._naks = 0  # NAKs received for _last_sent
        self._corrupt = 0  # corrupt packets received in a row
        self._resends = 0  # controller: timeout resends of _last_sent
        self._last_received = b""  # host: last answer data, for resend detection
        self._last_ack_at = 0.0
        self._backlog: list[FrameEvent] = []  # line input held during the application's turn
        self._resend_unsent = False  # a resend is in _out, not yet handed to the driver
        self._send_once = False  # host: the current exchange changes state (no doubtful resend)
        self._doubt = ""  # host: why the current exchange's outcome may be unknown
        self.overrun_frames = 0
        """Frames received while :data:`MAX_BACKLOG` were already held, and dropped (as a UART
        whose buffer is full loses what comes next)."""
        self.corrupt_frames = 0
        """Damaged frames received so far (a controller reports the last one's reason in KD)."""
        self.last_corrupt: CorruptReason | None = None

    # -- driver interface ------------------------------------------------------------------
    def receive_data(self, data: bytes, now: float) -> list[LinkEvent]:
        """Feed bytes from the line."""
        self._now = now
        backlog = self._backlog
        waiting = self.state in APP_TURN  # the application is busy with the last request
        backlog.extend(self.decoder.feed(data))
        if backlog:
            self._take_backlog()  # which tells of input held in the turn (_held_in_turn)
            if waiting and len(backlog) > MAX_BACKLOG:
                # A peer that keeps sending while its last request is being handled cannot
                # hold unbounded memory (one read's worth is held when the application is
                # free, as it takes the frames in turn before more are read).
                self.overrun_frames += len(backlog) - MAX_BACKLOG
                del backlog[MAX_BACKLOG:]
        return self._take_events()

    def data_to_send(self) -> bytes:
        """Bytes to write to the line now (empty when there are none)."""
        self._resend_unsent = False
        pending = self._out
        if not pending:
            return b""
        out = bytes(pending)
        pending.clear()
        return out

    def next_deadline(self) -> float | None:
        """When :meth:`handle_timeout` must be called, or None if no timer runs."""
        return self._deadline

    def handle_timeout(self, now: float) -> list[LinkEvent]:
        """Call when the deadline has passed; does nothing before it."""
        self._now = now
        if self._deadline is not None and now >= self._deadline:
            self._deadline = None
            self._fire(Input.TIMEOUT, b"")
        return self._take_events()

    def abort(self, now: float) -> list[LinkEvent]:
        """End the current exchange at once by sending RST (Ctrl-C, a jog that must stop)."""
        self._now = now
        self._fire(Input.ABORT, b"")
        if self._backlog:
            self._take_backlog()
        return self._take_events()

    @property
    def idle(self) -> bool:
        """In the idle state: a request may go out at once."""
        return self.state is self._idle

    @property
    def busy(self) -> bool:
        """An exchange is open (RESYNC, the quiet gap after an RST, is not an exchange)."""
        return self.state not in (self._idle, State.RESYNC)

    # -- table dispatch --------------------------------------------------------------------
    def _take_backlog(self) -> None:
        """Dispatch held line input until the application's turn comes (or nothing is left)."""
        while self._backlog and self.state not in APP_TURN:
            self._dispatch_frame(self._backlog.pop(0))
        if self._backlog:
            # The turn began with input already held behind it (read with the request, or
            # left from an earlier read): it is held in this turn as much as later input is.
            self._held_in_turn(self._backlog)

    def _dispatch_frame(self, event: FrameEvent) -> None:
        if isinstance(event, Packet):  # the usual event first
            self._fire(Input.PACKET, event.data)
            return
        if isinstance(event, CorruptPacket):
            self.corrupt_frames += 1
            self.last_corrupt = event.reason
        if isinstance(event, Control):
            self._fire(_CONTROL_INPUT[event.kind], b"")
        elif event.reason is CorruptReason.TRUNCATED:
            # A frame cut short by a new STX needs no NAK: the next frame is already arriving,
            # and a NAK here would make the sender resend a packet that may have been taken
            # (a duplicated STX byte would then run a command twice).
            self._emit(Ignored("frame cut short by a new STX", self.state))
        else:
            self._fire(Input.CORRUPT, event.raw)

    def _fire(self, what: Input, data: bytes) -> None:
        handler = self._handlers.get((self.state, what))
        if handler is None:
            error = LinkRuleError(self.role.value, self.state.value, what.value)
            if what in _APP_INPUTS:
                raise error
            self._rule_broken(error)
            return
        handler(self, data)

    def _take_events(self) -> list[LinkEvent]:
        events = self._events
        self._events = []
        return events

    # -- shared actions ----------------------------------------------------------------------
    def _emit(self, event: LinkEvent) -> None:
        self._events.append(event)

    def _send_packet(self, data: bytes, *, fresh: bool = True) -> None:
        self._send_frame(encode_packet(data), fresh=fresh)

    def _send_frame(self, frame: bytes, *, fresh: bool = True) -> None:
        """Send a packet already framed (by :func:`encode_packet`)."""
        self._out += frame
        self._last_sent = frame
        if fresh:
            self._naks = 0
            self._resends = 0

    def _send_control(self, byte: int) -> None:
        self._out.append(byte)

    def _arm(self, seconds: float) -> None:
        self._deadline = self._now + seconds

    def _extend(self, seconds: float) -> None:
        """Wait at least ``seconds`` from now, never less than already armed (a two-phase wait
        must not be cut short by a resend or a corrupt frame)."""
        if self._deadline is None or self._now + seconds > self._deadline:
            self._deadline = self._now + seconds

    def _finish(self, event: LinkEvent) -> None:
        self._deadline = None
        self.state = self._idle
        self._emit(event)

    def _fail(
        self,
        reason: FailReason,
        detail: str = "",
        *,
        send_rst: bool,
        error: LinkRuleError | None = None,
    ) -> None:
        state = self.state
        self._deadline = None
        self.state = self._idle
        if send_rst:
            self._send_control(RST)
            self.decoder.reset()
            self._after_rst()
        self._emit(ExchangeFailed(reason, state, detail, error))

    def _rule_broken(self, error: LinkRuleError) -> None:
        self._fail(FailReason.RULE, str(error), send_rst=True, error=error)

    def _after_rst(self) -> None:
        """Called when this end has just sent RST to end an exchange."""

    def _ignore(self, data: bytes) -> None:
        self._emit(Ignored("stray input", self.state))

    def _nak_corrupt(self, data: bytes) -> None:
        self._corrupt += 1
        if self._corrupt > MAX_NAKS:
            self._corrupt = 0
            if self.state is self._idle:
                self._send_control(RST)
                self._emit(Ignored("corrupt packet: RST after 3 NAKs", self.state))
                return
            self._fail(FailReason.NAK_LIMIT, "4th corrupt packet in a row", send_rst=True)
            return
        self._send_control(NAK)
        if self.state is not self._idle and self._deadline is not None:
            self._extend(self.timeout)

    def _resend(self, data: bytes) -> None:
        # One NAK allows one resend of the transmission it answers.
        if self._send_once and self._naks >= 1:
            # A state change is resent once. A later NAK may answer that resend (noise again)
            # or be a late copy of the first NAK (a doubled byte): then the resend reached the
            # controller, which may carry it out. No third copy: the answer decides, or the
            # outcome is unknown when none comes.
            self._doubt = "a NAK came after our resend (maybe a doubled one); not resent"
            self._emit(Ignored("NAK after our resend of a state change: not resent", self.state))
            return
        if self._resend_unsent and self.role is Role.HOST:
            # Our resend for an earlier NAK has not even gone out: this NAK cannot answer it.
            # It is the same NAK again (a doubled byte). (A controller resends an answer as
            # often as it is NAKed: a copy too many is the host's to recognise.)
            self._emit(Ignored("NAK before our resend went out (a doubled NAK)", self.state))
            return
        self._naks += 1
        if self._naks > MAX_NAKS:
            self._fail(FailReason.NAK_LIMIT, f"{self._naks} NAKs for one packet", send_rst=True)
            return
        self._out += self._last_sent
        self._resend_unsent = True
        self._arm(self.timeout)

    def _reset_by_peer(self, data: bytes) -> None:
        # An RST is only ever read between frames: nothing of the decoder's is to be dropped
        # (and a held RST must not drop the start of a frame that came after it).
        self._fail(FailReason.RESET, "RST received", send_rst=False)

    def _held_in_turn(self, frames: list[FrameEvent]) -> None:
        """``frames`` (all the input held) wait for the application's next call in its turn
        (see :data:`APP_TURN`); called whenever input is left held, so possibly again."""

    def _peer_moved_on(self) -> bool:
        """At the application's call in its turn: if the peer sent an RST or a packet meanwhile,
        it has moved on. Then nothing is sent: the exchange ends (RESET; SUPERSEDED for a new
        request, which is taken next; else a broken rule) and the held input follows in order.
        Held noise (ACK, NAK, a corrupt frame) does not count."""
        if self.state not in APP_TURN:
            return False
        for index, event in enumerate(self._backlog):
            if isinstance(event, Control) and event.kind is ControlKind.RST:
                del self._backlog[: index + 1]
                self._fail(FailReason.RESET, "RST arrived before this end's turn", send_rst=False)
                return True
            if isinstance(event, Packet):
                if self.role is Role.CONTROLLER and event.data[:1] == b"\xff":
                    del self._backlog[:index]
                    self._fail(FailReason.SUPERSEDED, "a new request came first", send_rst=False)
                    return True
                del self._backlog[: index + 1]
                self._rule_broken(
                    LinkRuleError(self.role.value, self.state.value, "packet", "during our turn")
                )
                return True
        return False

    def _abort(self, data: bytes) -> None:
        self._fail(FailReason.ABORTED, "aborted by the application", send_rst=True)

    def _good_packet(self) -> None:
        self._corrupt = 0


class HostLink(Link):
    """The PC's end: sends requests, ACKs answers, runs FB uploads.

    Two guards keep a faulty line from making a command run twice or an answer land on the
    wrong request. After this end sends RST it stays quiet until the line has been silent for
    ``resync_gap`` seconds (state RESYNC): a stale packet still in flight is answered with RST
    and restarts the gap (the whole resync ends at the latest when a controller resending an
    unacknowledged answer would have given up: ``(MAX_RESENDS + 1) * peer_resend_after +
    resend_grace`` after the RST), a NAK for an old frame is ignored, and a new request waits
    until the gap is over. (The client sets the gap to its reply timeout, so an answer held
    back by a device server for up to twice the timeout cannot land on the next request.) And
    after ACKing a packet that is not the last, it waits ``timeout + resend_grace`` for the
    next one, so that a controller resending after its own timeout (our ACK was lost) is heard
    before we give up.

    A copy of the answer just ACKed is only taken for the controller's resend when it comes
    late enough for one: the controller resends after its own timeout (``peer_resend_after``,
    the manual's 2 s; by default taken equal to ours). An equal answer sooner than 90 % of that
    is new data, so a slow controller (0.3 s, 1.5 s) that answers a repeated request with the
    same bytes is served at its own speed.

    Every exchange has one overall limit, set when its request goes out, that no behaviour of
    the peer can stretch (resent answers, NAKs, noise, a trickle of packets): ``timeout`` for
    each NAK allowed and the answer, ``timeout + resend_grace`` for each packet a multi-packet
    answer may hold (``max_packets``), and a two-phase answer's announced work time (two
    digits, at most ``max_wait`` s). After this end's own RST of an exchange (``abort``) the
    quiet gap is the whole ``resync_gap`` too (an answer held back by a device server can still
    be on its way), but a stop (:data:`STOP_CODES`) goes out once the line has been quiet for
    ``abort_gap``, so that a stop pre-empting a transfer is not held back. An answer packet
    with data (or an END) during such an early stop is stale, as a stop answers a bare flag:
    it is ignored. After the early stop's exchange the whole gap runs again before any other
    request, so that the stop's own answer, if a stale one was taken in its place, is stopped
    with RST instead of landing on the next request.
    """

    role = Role.HOST
    _idle = State.IDLE

    def __init__(
        self,
        *,
        timeout: float = 2.0,
        resend_gap: float = 0.25,
        resync_gap: float = 0.25,
        resend_grace: float = 0.5,
        peer_resend_after: float | None = None,
        max_wait: float = MAX_ANNOUNCED_WAIT,
        abort_gap: float = 0.05,
        fences: Sequence[Fence] = (),
    ):
        super().__init__(timeout=timeout, resend_gap=resend_gap)
        self.resync_gap = resync_gap
        self.resend_grace = resend_grace
        self.peer_resend_after = timeout if peer_resend_after is None else peer_resend_after
        """The controller's own resend timeout: an equal answer sooner than 90 % of it is new."""
        self.max_wait = min(max_wait, MAX_ANNOUNCED_WAIT)
        self.abort_gap = abort_gap
        self.shape = Shape.SINGLE
        self.fences = tuple(fences)
        """The reads that fence off an abandoned exchange (:class:`Fence`), in the order of
        preference; none: no fence (the quiet gap alone guards the next request)."""
        self._abandoned: dict[bytes, None] = {}  # codes of requests given up, oldest first
        self._fence: Fence | None = None  # WAIT_FENCE: the fence sent
        self._fenced: tuple[bytes, Shape, bool, int | None, bool] | None = None  # held behind it
        self._given_up_request = b""  # the request given up last
        self._retry_next = False  # retry_next() was called for the request to come
        self._deferred: tuple[bytes, Shape, bool, int | None, bool] | None = None
        self._request_at = 0.0
        self._resync_until = 0.0  # a resync gap, however often restarted, ends by then
        self._limit_at: float | None = None  # the exchange's overall limit
        self._max_packets = 1
        self._packets = 0
        self._distinct = False  # no two packets of the answer are equal (send_request)
        self._copies = 0  # copies taken for resends of the packet ACKed last,
        self._copies_of = -1  # which is this exchange's packet number _copies_of
        self._progress_by: float | None = None  # WAIT_MORE: a new packet must come by then
        self._bytes = 0
        self._maybe_answer = b""  # a read's copy taken for a resend, delivered if nothing else
        self._last_reply = b""  # FB: the controller's last reply to one of our packets
        self._aborting = False
        self._quiet_at = 0.0  # RESYNC: when the line will have been quiet for the whole gap
        self._stop_at: float | None = None  # RESYNC after our abort: when a stop may go out
        self._stop_early = False  # the exchange open is a stop sent before the gap was over
        self._request_data: bytes | None = None  # the last request sent, and its frame
        self._request_frame = b""
        self._clean_read = b""  # the last read receive_clean_answer found one whole frame in,
        self._clean_packet = b""  # and that frame's packet

    # -- application calls -----------------------------------------------------------------
    def send_request(
        self,
        data: bytes,
        shape: Shape,
        now: float,
        *,
        once: bool = False,
        max_packets: int | None = None,
        distinct: bool = False,
    ) -> list[LinkEvent]:
        """Start an exchange with a request packet's data (``FF G1 G2 params``).

        ``once``: the request changes state, so it is never resent on a NAK that may be a
        doubled one. ``max_packets``: the most answer packets (MULTI; END included) the
        command can carry; past it (or its bytes) the answer is cut with RST (TOO_LONG).
        ``distinct``: no two packets of the answer are equal, so a copy of the packet just
        ACKed is the controller resending it however soon it comes (see :data:`MAX_RESENDS`).
        """
        self._now = now
        self._pending_shape = shape
        self._pending_once = once
        self._pending_max = max_packets
        self._pending_distinct = distinct
        self._fire(Input.SEND_REQUEST, data)
        if self._backlog:
            self._take_backlog()
        events = self._events  # _take_events(), inline: every request passes here
        self._events = []
        return events

    def receive_clean_answer(self, data: bytes, now: float) -> bytes | None:
        """The usual read of a single exchange, in one step: when ``data`` is exactly one
        whole frame with a good LRC (:func:`~robostar.protocol.frame.lone_frame`) holding an
        OK answer (flag 0x30; not one taken for the controller resending the answer ACKed
        last) to the SINGLE request this link waits on, with nothing held and no frame begun,
        the link does what :meth:`receive_data` does with it (ACK it, end the exchange) and
        returns the packet's data. The events :meth:`receive_data` would have returned are
        then exactly ``[AnswerReceived(packet, 0x30, final=True), ExchangeComplete()]``; none
        are made.

        Otherwise it returns None and has changed nothing: give the same bytes to
        :meth:`receive_data`, whose rules decide.
        """
        if (
            self.state is not State.WAIT_ANSWER
            or self.shape is not Shape.SINGLE
            or type(data) is not bytes
            or self._backlog
            or not self.decoder.between_frames
            or self._stop_early
        ):
            return None
        if data == self._clean_read:
            # The same bytes as the last clean answer (a poll answered alike): the same packet.
            packet = self._clean_packet
        else:
            found = lone_frame(data)
            if found is None:
                return None
            packet = self._clean_packet = found
            self._clean_read = data
        if (
            packet == self._last_received
            # _is_resend's timing test first, inline: every poll answered alike comes here,
            # and a copy sooner than the controller's resend is new data
            and now - self._last_ack_at >= _RESEND_SHARE * self.peer_resend_after
            and self._is_resend(packet, now)
        ):
            return None
        # The flag as _flag_of reads it: a leading FF is the dummy byte.
        offset = 1 if packet[:1] == b"\xff" else 0
        size = len(packet)
        if (
            size <= offset
            or packet[offset] != FLAG_OK
            or self._packets >= self._max_packets
            or self._bytes + size > self._max_packets * MAX_PACKET
        ):
            return None
        # _h_answer's steps for this packet, then _finish (in that order in _h_answer).
        self._now = now
        self._corrupt = 0
        self._packets += 1
        self._bytes += size
        self._out.append(ACK)
        self._last_received = packet
        self._last_ack_at = now
        self._limit_at = None
        self._deadline = None
        self.state = State.IDLE
        return packet

    def retry_next(self) -> None:
        """The next request is the application asking the same call again (a read whose
        answer was lost): if it is the request given up last, it needs no fence, since a late
        answer to it answers this call (see ``_needs_fence``)."""
        self._retry_next = True

    def send_upload_line(self, body: bytes, now: float) -> list[LinkEvent]:
        """FB: send one content packet (``0x30`` + body) after :class:`UploadReady`."""
        self._now = now
        self._fire(Input.SEND_LINE, body)
        if self._backlog:
            self._take_backlog()
        return self._take_events()

    def send_upload_end(self, now: float) -> list[LinkEvent]:
        """FB: send the closing 0x34 packet; a lone ACK completes the upload."""
        self._now = now
        self._fire(Input.SEND_END, b"")
        if self._backlog:
            self._take_backlog()
        return self._take_events()

    # -- handlers --------------------------------------------------------------------------
    def _send_fence(self, data: bytes) -> None:
        """An exchange was given up since the last clean answer: its answer may still come.
        A fence read goes first; the request ``data`` waits behind it (stops never do)."""
        self._fenced = (
            data,
            self._pending_shape,
            self._pending_once,
            self._pending_max,
            self._pending_distinct,
        )
        fence = self._fence = self._pick_fence()
        self._pending_shape, self._pending_once = Shape.SINGLE, False
        self._pending_max, self._pending_distinct = None, False
        self._h_send_request(fence.request)  # no fence before it: one is open (_needs_fence)
        self.state = State.WAIT_FENCE

    def _pick_fence(self) -> Fence:
        """The first fence whose own read was not given up (its answer could be late too); if
        every one was, the one given up longest ago."""
        abandoned = self._abandoned
        for fence in self.fences:
            if fence.code not in abandoned:
                return fence
        order = list(abandoned)
        return min(self.fences, key=lambda fence: order.index(fence.code))

    def _h_fence_answer(self, data: bytes) -> None:
        self._good_packet()
        fence = self._fence
        assert fence is not None and self._fenced is not None
        if _flag_of(data) != FLAG_OK or not fence.accepts(data):
            # Sent before the fence's answer, so by an exchange we gave up: dropped, not ACKed
            # (the controller dropped that exchange at our RST, or at the fence's request).
            self._emit(Ignored("stale packet before the fence's answer (dropped)", self.state))
            return
        self._ack(data)
        self._abandoned.clear()
        self._fence = None
        fenced, self._fenced = self._fenced, None
        data, self._pending_shape, self._pending_once, self._pending_max = fenced[:4]
        self._pending_distinct = fenced[4]
        self._h_send_request(data)

    def _h_send_request(self, data: bytes) -> None:
        if self._abandoned and self._needs_fence(data):
            self._send_fence(data)
            return
        shape = self.shape = self._pending_shape
        now = self._now
        self._corrupt = 0
        self._request_at = now
        self._send_once = self._pending_once or shape is Shape.UPLOAD
        self._doubt = ""
        self._maybe_answer = b""
        self._packets = self._bytes = 0
        self._distinct = self._pending_distinct
        self._copies_of = -1  # no copy counted yet in this exchange
        if shape is Shape.MULTI:
            max_packets = self._pending_max or MAX_MULTI_PACKETS
        else:
            max_packets = 2 if shape is Shape.TWO_PHASE else 1
        self._max_packets = max_packets
        timeout = self.timeout
        if shape is Shape.UPLOAD:
            # FB's replies are never ACKed: a later copy of the answer before it is no resend.
            self._last_received = b""
            self._last_reply = b""
            self._limit_at = None  # each line is its own transmission, each with a timer
        else:
            per_packet = timeout + self.resend_grace
            self._limit_at = now + timeout * (MAX_NAKS + 1) + per_packet * max_packets
        # _send_packet(data), the frame of a request sent again (a poll) made once
        if data == self._request_data:
            frame = self._request_frame
        else:
            frame = encode_packet(data)
            self._request_data = data
            self._request_frame = frame
        # _send_frame(frame), then _arm(timeout), inline: every request passes here.
        self._out += frame
        self._last_sent = frame
        self._naks = 0
        self._resends = 0
        self.state = State.UPLOAD_WAIT_REPLY if shape is Shape.UPLOAD else State.WAIT_ANSWER
        deadline = now + timeout
        limit = self._limit_at
        if limit is not None and deadline > limit:
            deadline = limit
        self._deadline = deadline

    def _arm(self, seconds: float) -> None:
        # Link._arm, then _clamp, inline: every request and every answer arms a timer.
        deadline = self._now + seconds
        limit = self._limit_at
        if limit is not None and deadline > limit and self.state not in _NOT_BUSY:
            deadline = limit
        self._deadline = deadline

    def _extend(self, seconds: float) -> None:
        super()._extend(seconds)
        self._clamp()

    def _clamp(self) -> None:
        """No timer of an exchange runs past the exchange's overall limit, nor a multi-packet
        answer's wait past the moment its next new packet is due (``_progress_by``)."""
        limit = self._limit_at
        if limit is not None and self.busy and self._deadline is not None:
            self._deadline = min(self._deadline, limit)
        progress = self._progress_by
        if progress is not None and self.state is State.WAIT_MORE and self._deadline is not None:
            self._deadline = min(self._deadline, progress)

    def _finish(self, event: LinkEvent) -> None:
        self._limit_at = None
        self._deadline = None  # Link._finish, inline: every exchange ends here
        self.state = self._idle
        self._events.append(event)
        if self._stop_early:
            self._after_early_stop()

    def _fail(
        self,
        reason: FailReason,
        detail: str = "",
        *,
        send_rst: bool,
        error: LinkRuleError | None = None,
    ) -> None:
        self._limit_at = None
        if send_rst and self.state not in _NOT_BUSY:
            self._given_up()
            if self.state is State.WAIT_FENCE:
                self._fence = self._fenced = None
                detail = f"{detail}; the fence before the request failed: it was not sent"
        super()._fail(reason, detail, send_rst=send_rst, error=error)
        if self._stop_early:
            self._after_early_stop()

    def _after_rst(self) -> None:
        self._last_received = b""  # nothing of an exchange we reset is to be ACKed again
        # An answer may still be on its way, held back anywhere (a device server with 0.3 s
        # of latency holds it longer than any short gap): the whole gap, after our own abort
        # too, else that answer lands on the next request. Only a stop may go out sooner
        # after our abort (``abort_gap``): a stop pre-empting a transfer must not wait, and
        # stale data cannot pass for its bare-flag answer (see _h_answer).
        gap = self.resync_gap
        if self._aborting:
            gap = max(gap, self.abort_gap)
            self._stop_at = self._now + self.abort_gap
        else:
            self._stop_at = None
        self._stop_early = False  # the RST ended it: the resync now decides
        if gap > 0:
            self._enter_resync(gap)

    def _enter_resync(self, gap: float) -> None:
        self.state = State.RESYNC
        # However chatty the line, the resync ends by then (a request deferred meanwhile
        # waits no longer): a controller resending an unacknowledged answer has given up
        # after its last resend, and what still comes is not a resend.
        self._resync_until = (
            self._now + (MAX_RESENDS + 1) * self.peer_resend_after + (self.resend_grace)
        )
        self._quiet_at = self._now + gap
        self._deadline = self._quiet_at

    def _after_early_stop(self) -> None:
        """A stop that went out before the quiet gap was over has ended: the whole gap again
        before anything else. Its answer may have been a stale one (a bare flag of the aborted
        exchange), and then its own answer is still coming: in the gap it meets RST, never the
        next request. Further stops still go out at once."""
        self._stop_early = False
        if self.state is State.IDLE and self.resync_gap > 0:
            self._enter_resync(self.resync_gap)
            self._stop_at = self._now

    def _is_stop_now(self, data: bytes) -> bool:
        """In the gap after our own abort: may this request go out now, before the gap ends?"""
        stop_at = self._stop_at
        if stop_at is None or data[1:3] not in EARLY_CODES:
            return False
        # Once the whole gap is over a stop is no longer early: it goes out as any request.
        return stop_at <= self._now < self._quiet_at

    def _abort(self, data: bytes) -> None:
        self._aborting = True
        try:
            super()._abort(data)
        finally:
            self._aborting = False

    def _h_defer_request(self, data: bytes) -> None:
        if self._deferred is not None:
            raise LinkRuleError("host", self.state.value, Input.SEND_REQUEST.value, "one waits")
        encode_packet(data)  # a bad request is refused now, not when the gap ends
        self._deferred = (
            data,
            self._pending_shape,
            self._pending_once,
            self._pending_max,
            self._pending_distinct,
        )
        # The gap may be over already (a blocking client's link is not woken between calls).
        self._send_when_due()

    def _h_drop_deferred(self, data: bytes) -> None:
        if self._deferred is not None:
            self._deferred = None
            self._deadline = self._quiet_at  # no stop waits any more
            self._emit(ExchangeFailed(FailReason.ABORTED, self.state, "aborted before it was sent"))

    def _h_resync_done(self, data: bytes) -> None:
        self._send_when_due()

    def _send_when_due(self) -> None:
        """End the resync (the deferred request, if any, goes out) once the line has been
        quiet for the whole gap; before that, send a deferred stop whose ``abort_gap`` has
        passed, or wait for the first of the two."""
        if self._now >= self._quiet_at:
            self._send_deferred(early=False)
            return
        deferred = self._deferred
        if deferred is not None and self._is_stop_now(deferred[0]):
            self._send_deferred(early=True)
        else:
            self._deadline = self._wake_at()

    def _wake_at(self) -> float:
        """When the resync's timer is due: the gap's end, or a deferred stop's ``abort_gap``
        if that comes first."""
        deferred = self._deferred
        if self._stop_at is not None and deferred is not None and deferred[0][1:3] in EARLY_CODES:
            return min(self._quiet_at, self._stop_at)
        return self._quiet_at

    def _send_deferred(self, *, early: bool) -> None:
        self.state = State.IDLE
        self._stop_at = None
        deferred, self._deferred = self._deferred, None
        if deferred is not None:
            (
                data,
                self._pending_shape,
                self._pending_once,
                self._pending_max,
                self._pending_distinct,
            ) = deferred
            self._h_send_request(data)
            self._stop_early = early

    def _given_up(self) -> None:
        """This end gave up the request sent last (with its RST): its answer may still come."""
        request = self._request_data or b""  # the request sent last
        code = request[1:3]
        self._abandoned.pop(code, None)
        self._abandoned[code] = None
        self._given_up_request = request
        self._retry_next = False  # a retry_next() before this was for the request given up

    def _needs_fence(self, data: bytes) -> bool:
        """Must ``data`` wait behind a fence? When an exchange was given up since the last
        fence, unless ``data`` is a stop (never held back) or the application's retry of the
        very request given up, alone (a late answer of the first try answers the same call;
        the given-up mark stays, so the next other request or call is fenced)."""
        abandoned = self._abandoned
        if self._fence is not None or not self.fences or data[1:3] in EARLY_CODES:
            return False  # (a fence being sent is not fenced itself)
        retry, self._retry_next = self._retry_next, False
        return len(abandoned) > 1 or not (retry and data == self._given_up_request)

    def _h_stray_packet(self, data: bytes) -> None:
        # An intact packet outside an exchange. A copy of the last answer we ACKed is the
        # controller resending it (our ACK was lost): ACK it again so that it stops. Anything
        # else belongs to an exchange we gave up (a multi-packet answer still coming): RST, so
        # that it stops instead of running into our next request.
        self._good_packet()
        if data and data == self._last_received:
            self._send_control(ACK)
            self._emit(Ignored("resent answer outside an exchange (ACKed again)", self.state))
        else:
            self._send_control(RST)
            self._emit(Ignored("stale packet outside an exchange (RST)", self.state))

    def _h_resync_packet(self, data: bytes) -> None:
        # A packet of the exchange we just reset is still coming: stop it, and wait for the
        # line to be quiet for the whole gap again before the next request goes out.
        self._good_packet()
        self._send_control(RST)
        self._rearm_resync()
        self._emit(Ignored("stale packet in the resync gap (RST)", self.state))

    def _h_resync_noise(self, data: bytes) -> None:
        self._rearm_resync()
        self._emit(Ignored("corrupt frame in the resync gap", self.state))

    def _rearm_resync(self) -> None:
        """The line is not quiet: wait the whole gap again, but not past the resync's end (a
        stop after our abort: ``abort_gap`` again, within the same bound)."""
        now = self._now
        left = max(0.0, self._resync_until - now)
        self._quiet_at = now + min(self.resync_gap, left)
        stop_at = self._stop_at
        if stop_at is not None:
            self._stop_at = max(stop_at, now + min(self.abort_gap, left))
        self._deadline = self._wake_at()

    def _is_resend(self, data: bytes, now: float) -> bool:
        """Is ``data``, arriving at ``now``, the controller resending the answer we ACKed last
        (our ACK was lost)?"""
        if data != self._last_received:
            return False
        if self.state is State.WAIT_SECOND and len(split_answer(data).body) == 0:
            # CE's two answers are both a bare flag: a copy is the second answer, not a resend.
            return False
        # The controller resends only after its own timeout: a copy sooner than that is new
        # data (a slow controller answering the same request with the same bytes).
        if now - self._last_ack_at < _RESEND_SHARE * self.peer_resend_after:
            return False
        if self.state is State.WAIT_ANSWER:
            # The previous exchange's last answer again, late, while our request went out
            # right behind our ACK of it: the controller did not get that ACK in time and is
            # resending. A request sent later is answered after it: the copy is its answer.
            return self._request_at - self._last_ack_at < self.resend_gap
        return True

    def _ack(self, data: bytes) -> None:
        self._out.append(ACK)
        self._last_received = data
        self._last_ack_at = self._now

    def _h_answer(self, data: bytes) -> None:
        self._corrupt = 0  # _good_packet(), inline
        if self._stop_early and (
            _flag_of(data) == FLAG_END or len(data) > (2 if data[:1] == b"\xff" else 1)
        ):
            # A stop answers a bare flag: data (or an END) is the aborted exchange's, still
            # arriving. Not ACKed (the controller dropped that exchange at our RST).
            self._emit(Ignored("stale packet with data in a stop's answer", self.state))
            return
        if data == self._last_received and (
            (self._distinct and self._packets) or self._is_resend(data, self._now)
        ):
            if self._copies_of != self._packets:  # the first copy of this packet
                self._copies_of = self._packets
                self._copies = 0
            self._copies += 1
            if self._packets and self._copies > MAX_RESENDS:
                # A copy of a packet of this exchange: the controller resends an unacknowledged
                # packet at most MAX_RESENDS times; a copy beyond that is no resend.
                self._rule_broken(
                    LinkRuleError(
                        "host",
                        self.state.value,
                        "packet",
                        f"copy {self._copies + 1} of one packet: a controller resends at "
                        f"most {MAX_RESENDS} times",
                    )
                )
                return
            self._ack(data)
            self._emit(Ignored("resent answer (ACKed again)", self.state))
            if self.state is State.WAIT_ANSWER and not self._send_once:
                # It could also be a very slow controller's answer: a read takes it if no
                # other answer comes (a state change would rather be unknown than wrong).
                # Not when it came again (a slow controller answers once; a resending one
                # up to MAX_RESENDS times), nor an END to an exchange that has none.
                fits = self.shape is Shape.MULTI or _flag_of(data) != FLAG_END
                self._maybe_answer = data if self._copies == 1 and fits else b""
            # Never shorten the wait: in WAIT_SECOND it runs to the announced work time.
            self._extend(self.timeout + self.resend_grace)
            return
        if data == self._last_received and self._backlog and _holds_packet(self._backlog):
            # A copy of the packet we ACKed last with another packet right behind it, in the
            # same read: the controller sent it without waiting for an ACK, which a controller
            # answering us never does (it sends the next packet only after our ACK, and
            # resends only after its timeout). It repeats its previous answer: not data.
            self._emit(Ignored("a repeat of the last packet, sent without waiting", self.state))
            return
        flag = _flag_of(data)
        if flag not in (FLAG_OK, FLAG_END) and flag not in _ERROR_FLAGS:
            self._rule_broken(
                LinkRuleError("host", self.state.value, "packet", f"unknown flag in {data!r}")
            )
            return
        self._packets += 1
        self._bytes += len(data)
        if self._packets > self._max_packets or self._bytes > self._max_packets * MAX_PACKET:
            what = f"{self._packets} packets, {self._bytes} bytes"
            limit = f"{self._max_packets} packets of at most {MAX_PACKET} bytes"
            self._fail(FailReason.TOO_LONG, f"{what}: more than {limit}", send_rst=True)
            return
        self._ack(data)
        if flag in _ERROR_FLAGS:
            self._emit(AnswerReceived(data, flag, final=True))
            self._finish(_COMPLETE)
            return
        shape = self.shape
        if shape is Shape.MULTI:
            if flag == FLAG_END:
                self._emit(AnswerReceived(data, flag, final=True))
                self._finish(_COMPLETE)
            else:
                self._emit(AnswerReceived(data, flag, final=False))
                self.state = State.WAIT_MORE
                # Progress, not only the overall limit: by then a controller resending this
                # packet (our ACK lost) has given up, so a new packet must have come.
                self._progress_by = (
                    self._now + (MAX_RESENDS + 1) * self.peer_resend_after + self.resend_grace
                )
                self._arm(self.timeout + self.resend_grace)
            return
        if flag == FLAG_END:
            self._rule_broken(
                LinkRuleError("host", self.state.value, "END packet", f"{shape.value} exchange")
            )
            return
        if shape is Shape.TWO_PHASE and self.state is State.WAIT_ANSWER:
            wait = announced_wait(data)
            if wait is None:
                self._rule_broken(
                    LinkRuleError(
                        "host",
                        self.state.value,
                        "first answer",
                        f"announced wait {split_answer(data).body!r} is not two digits",
                    )
                )
                return
            self._emit(AnswerReceived(data, flag, final=False))
            self.state = State.WAIT_SECOND
            wait = min(wait, self.max_wait)
            if self._limit_at is not None:
                self._limit_at += wait
            self._arm(wait + self.timeout + self.resend_grace)
            return
        self._emit(AnswerReceived(data, flag, final=True))
        self._finish(_COMPLETE)

    def _h_timeout(self, data: bytes) -> None:
        if self.state is State.WAIT_ANSWER and self._maybe_answer:
            # A read whose only answer was an equal copy of the previous one, taken for a
            # resend: nothing else came, so it was a slow controller's answer after all.
            answer, self._maybe_answer = self._maybe_answer, b""
            self._emit(AnswerReceived(answer, _flag_of(answer), final=True))
            self._finish(_COMPLETE)
            return
        if self._limit_at is not None and self._now >= self._limit_at:
            detail = "the exchange ran past its overall limit"
        elif (
            self.state is State.WAIT_MORE
            and self._progress_by is not None
            and self._now >= self._progress_by
        ):
            detail = "no new packet since a resending controller would have given up"
        else:
            detail = f"no answer within {self.timeout:g} s"
        if self._doubt:
            detail += f" ({self._doubt})"
        # Resync: RST returns the controller to its idle state too.
        self._fail(FailReason.TIMEOUT, detail, send_rst=True)

    def _h_upload_reply(self, data: bytes) -> None:
        self._good_packet()
        if data == self._last_reply and self._backlog and _holds_packet(self._backlog):
            # Two replies in one read: the controller answers each packet once, so the first,
            # a copy of its previous reply, is a repeat and accepts nothing.
            self._emit(Ignored("a repeat of the last reply, sent without waiting", self.state))
            return
        self._last_reply = data
        flag = _flag_of(data)
        if flag == FLAG_OK:
            self.state = State.UPLOAD_READY
            self._deadline = None
            self._emit(UploadReady(data))
        elif flag in _ERROR_FLAGS:
            self._emit(AnswerReceived(data, flag, final=True))
            self._finish(_COMPLETE)
        else:
            self._rule_broken(
                LinkRuleError("host", self.state.value, "packet", f"upload reply {data!r}")
            )

    def _h_send_line(self, body: bytes) -> None:
        if self._peer_moved_on():
            return
        self._send_packet(bytes((FLAG_OK,)) + body)
        self.state = State.UPLOAD_WAIT_REPLY
        self._arm(self.timeout)

    def _h_send_end(self, data: bytes) -> None:
        if self._peer_moved_on():
            return
        self._send_packet(bytes((FLAG_END,)))
        self.state = State.UPLOAD_WAIT_ACK
        self._arm(self.timeout)

    def _h_upload_done(self, data: bytes) -> None:
        self._finish(_COMPLETE)

    def _h_upload_final_reply(self, data: bytes) -> None:
        # The controller could not store the file: an error answer in place of the ACK.
        self._good_packet()
        flag = _flag_of(data)
        if flag in _ERROR_FLAGS:
            self._emit(AnswerReceived(data, flag, final=True))
            self._finish(_COMPLETE)
        else:
            self._rule_broken(
                LinkRuleError("host", self.state.value, "packet", f"{data!r} in place of ACK")
            )


class ControllerLink(Link):
    """The controller's end: receives requests, sends answers, takes FB uploads."""

    role = Role.CONTROLLER
    _idle = State.LISTEN

    def __init__(self, *, timeout: float = 2.0, max_resends: int = MAX_RESENDS):
        super().__init__(timeout=timeout)
        self.max_resends = max_resends
        self._queue: list[bytes] = []  # the answer's later packets, framed
        self._after = After.DONE
        self._told_moved_on = False  # PeerMovedOn reported in the current turn

    def _abort(self, data: bytes) -> None:
        # An abort in the application's turn is its call there like an answer: if the host
        # has moved on meanwhile (an RST, a new request), nothing is sent. An RST now would
        # land on the host's next exchange, which it would take as refused while the held
        # request is then served: a host that retried would run it twice.
        if self._peer_moved_on():
            return
        super()._abort(data)

    # -- application calls -----------------------------------------------------------------
    def send_answer(self, packets: Sequence[bytes], after: After, now: float) -> list[LinkEvent]:
        """Answer the current request (or upload packet) with one or more packets' data."""
        if not packets:
            raise UsageError("send_answer: packets must hold at least one packet")
        # Later packets go out only after ACKs; refuse a bad one now, before any is sent (and
        # keep the frames: each is sent as framed here).
        frames = [encode_packet(data) for data in packets]
        self._now = now
        self._pending = (frames, after)
        self._fire(Input.SEND_ANSWER, b"")
        if self._backlog:
            self._take_backlog()
        return self._take_events()

    def accept_upload(self, now: float) -> list[LinkEvent]:
        """FB: the closing 0x34 was stored; answer with a lone ACK."""
        self._now = now
        self._fire(Input.ACCEPT_UPLOAD, b"")
        if self._backlog:
            self._take_backlog()
        return self._take_events()

    # -- handlers --------------------------------------------------------------------------
    def _held_in_turn(self, frames: list[FrameEvent]) -> None:
        # the rule _peer_moved_on applies at the application's next call; told now, once
        if not self._told_moved_on and any(map(_moves_on, frames)):
            self._told_moved_on = True
            self._emit(PeerMovedOn(self.state))

    def _c_request(self, data: bytes) -> None:
        self._good_packet()
        self.state = State.HANDLING
        self._told_moved_on = False
        self._emit(RequestReceived(data))

    def _c_send_answer(self, data: bytes) -> None:
        if self._peer_moved_on():
            return
        frames, after = self._pending
        self._queue = frames[1:]
        self._after = after
        self._send_frame(frames[0])
        self._after_send()

    def _after_send(self) -> None:
        if self._queue or self._after in (After.DONE, After.SECOND_PHASE):
            self.state = State.WAIT_ACK
            self._arm(self.timeout)
        elif self._after is After.UPLOAD:
            self.state = State.UPLOAD_WAIT_PACKET
            self._arm(self.timeout)
        else:  # FINAL
            self._finish(_COMPLETE)

    def _c_acked(self, data: bytes) -> None:
        if self._queue:
            self._send_frame(self._queue.pop(0))
            self._after_send()
        elif self._after is After.SECOND_PHASE:
            self.state = State.WORKING
            self._after = After.DONE
            self._deadline = None
        else:
            self._finish(_COMPLETE)

    def _c_ack_timeout(self, data: bytes) -> None:
        if self._resends < self.max_resends:
            self._resends += 1
            self._out += self._last_sent
            self._arm(self.timeout)
        else:
            self._fail(FailReason.TIMEOUT, "no ACK after resends; exchange dropped", send_rst=False)

    def _c_superseded(self, data: bytes) -> None:
        # The host moved on: its ACK was lost (or it gave up and its RST was lost). A packet
        # that is a request starts a new exchange; the old one ends.
        if data[:1] != b"\xff":
            self._rule_broken(LinkRuleError("controller", self.state.value, "non-request packet"))
            return
        if self.state is State.WAIT_ACK and not self._queue and self._after is After.DONE:
            self._finish(_COMPLETE)
        else:
            self._fail(FailReason.SUPERSEDED, "a new request arrived", send_rst=False)
        self._c_request(data)

    def _c_upload_packet(self, data: bytes) -> None:
        self._good_packet()
        self._told_moved_on = False  # a new turn (or none: a request, a broken rule)
        if data[:1] == b"\xff":
            self._fail(FailReason.SUPERSEDED, "a new request arrived mid-upload", send_rst=False)
            self._c_request(data)
            return
        if data[:1] == bytes((FLAG_OK,)):
            self.state = State.UPLOAD_HANDLING
            self._deadline = None
            self._emit(UploadPacketReceived(data[1:], end=False))
        elif data == bytes((FLAG_END,)):
            self.state = State.UPLOAD_HANDLING
            self._deadline = None
            self._emit(UploadPacketReceived(b"", end=True))
        else:
            self._rule_broken(
                LinkRuleError("controller", self.state.value, "packet", f"{data!r} in upload")
            )

    def _c_upload_timeout(self, data: bytes) -> None:
        self._fail(FailReason.TIMEOUT, "upload stalled; exchange dropped", send_rst=False)

    def _c_accept_upload(self, data: bytes) -> None:
        if self._peer_moved_on():
            return
        self._send_control(ACK)
        self._finish(_COMPLETE)


def _moves_on(event: FrameEvent) -> bool:
    """Input that shows the peer gave up the exchange when it arrives in the application's
    turn: an RST or any packet (``Link._peer_moved_on``). ACK, NAK and damaged frames are
    noise."""
    return isinstance(event, Packet) or (
        isinstance(event, Control) and event.kind is ControlKind.RST
    )


def _holds_packet(backlog: list[FrameEvent]) -> bool:
    return any(isinstance(e, Packet) for e in backlog)


def _flag_of(data: bytes) -> int:
    """An answer packet's flag, or -1 when the packet is too short to hold one (as
    :func:`~robostar.protocol.packets.split_answer` reads it: a leading FF is the dummy)."""
    offset = 1 if data[:1] == b"\xff" else 0
    return data[offset] if len(data) > offset else -1


def announced_wait(data: bytes) -> float | None:
    """Seconds of a two-phase first answer's expected wait: DB/DC carry two digits (spaces or
    one digit tolerated), CE nothing (0). None: not a wait (the answer is malformed)."""
    text = split_answer(data).body.decode("ascii", "replace").strip()
    if not text:
        return 0.0
    if len(text) > 2 or not text.isdigit() or not text.isascii():
        return None
    return float(text)
