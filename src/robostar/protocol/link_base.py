"""The link state machine's common part for both roles: the driver interface, the dispatch of
line and application input through :data:`~robostar.protocol.link_table.TRANSITIONS`, and the
actions both ends share (send, NAK, resend, fail, hold input in the application's turn)."""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

from robostar.errors import LinkRuleError
from robostar.protocol.frame import (
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
)
from robostar.protocol.link_events import ExchangeFailed, Ignored, LinkEvent
from robostar.protocol.link_table import (
    _APP_INPUTS,
    APP_TURN,
    MAX_BACKLOG,
    MAX_NAKS,
    TRANSITIONS,
    FailReason,
    Input,
    Role,
    State,
)
from robostar.protocol.packets import split_answer

_Handler = Callable[["Link", bytes], None]

_RESEND_SHARE = 0.9
"""An answer equal to the last one ACKed is the controller resending it (its ACK lost) only
from this share of the controller's resend timeout on; sooner, it is new data."""

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
            self._cut_short()
        else:
            self._fire(Input.CORRUPT, event.raw)

    def _cut_short(self) -> None:
        """A frame was cut short by a new STX."""
        self._emit(Ignored("frame cut short by a new STX", self.state))

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


def _moves_on(event: FrameEvent) -> bool:
    """Input that shows the peer gave up the exchange when it arrives in the application's
    turn: an RST or any packet (``Link._peer_moved_on``). ACK, NAK and damaged frames are
    noise."""
    return isinstance(event, Packet) or (
        isinstance(event, Control) and event.kind is ControlKind.RST
    )


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
