"""The PC's end of the link: requests, answers, uploads. Its resync rules, fence, timers and
clean-answer fast path are mixins of their own modules (``link_resync``, ``link_fence``,
``link_timers``, ``link_fast``)."""

from __future__ import annotations

from collections.abc import Sequence

from robostar.errors import LinkRuleError
from robostar.protocol.fields import FLAG_END, FLAG_OK
from robostar.protocol.frame import (
    _CONTROL_BYTES,
    MAX_PACKET,
    STX,
    CorruptPacket,
    Packet,
    encode_packet,
)
from robostar.protocol.link_base import (
    _ERROR_FLAGS,
    _RESEND_SHARE,
    Link,
    _flag_of,
    announced_wait,
)
from robostar.protocol.link_events import (
    _COMPLETE,
    AnswerReceived,
    Fence,
    Ignored,
    LinkEvent,
    UploadReady,
)
from robostar.protocol.link_fast import CleanAnswer
from robostar.protocol.link_fence import FenceRules
from robostar.protocol.link_resync import ResyncRules
from robostar.protocol.link_table import (
    _NOT_BUSY,
    MAX_ANNOUNCED_WAIT,
    MAX_MULTI_PACKETS,
    MAX_NAKS,
    MAX_RESENDS,
    FailReason,
    Input,
    Role,
    State,
)
from robostar.protocol.link_timers import HostTimers
from robostar.protocol.packets import Shape, split_answer

_RECEIVING = frozenset((State.WAIT_ANSWER, State.WAIT_MORE))
"""The states a multi-packet answer arrives in."""
_MULTI = Shape.MULTI


def _noise_then_frame(data: bytes) -> bool:
    """Does ``data``, read between frames, hold bytes that are no frame (nor ACK, NAK, RST)
    before its first STX?"""
    start = data.find(STX)
    return start > 0 and any(byte not in _CONTROL_BYTES for byte in data[:start])


class HostLink(FenceRules, ResyncRules, CleanAnswer, HostTimers, Link):
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
        self._after_lost = False  # in this read, bytes that were no whole frame came first
        self._watch_read = False  # this read may show a controller ahead (receive_data)
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

    def _abort(self, data: bytes) -> None:
        self._aborting = True
        try:
            super()._abort(data)
        finally:
            self._aborting = False

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

    def _h_answer(self, data: bytes) -> None:
        if self.receive_clean_answer(Packet(data), self._now) is not None:
            # The one accept step of a clean answer (link_fast), which the usual read takes
            # straight from the line: taken, ACKed, the exchange over. Here it is told.
            self._emit(AnswerReceived(data, FLAG_OK, final=True))
            self._emit(_COMPLETE)
            return
        self._corrupt = 0  # _good_packet(), inline
        if self._stop_early and (
            _flag_of(data) == FLAG_END or len(data) > (2 if data[:1] == b"\xff" else 1)
        ):
            # A stop answers a bare flag: data (or an END) is the aborted exchange's, still
            # arriving. Not ACKed (the controller dropped that exchange at our RST).
            self._emit(Ignored("stale packet with data in a stop's answer", self.state))
            return
        if self.shape is Shape.MULTI and data == self._last_received and self._sent_behind():
            # A copy of the packet we ACKed last with another frame right behind it, in the
            # same read, so sent without waiting for our ACK: the line (or the controller)
            # repeating the previous packet before the next, or a controller a packet ahead of
            # our ACKs (it took a doubled ACK byte for two) sending two equal packets, such as
            # two equal lines of a job. Where no two packets are equal (FD, FH) it is a
            # repeat: not data, and not ACKed (an ACK would count for the frame behind it, and
            # a NAK of that frame would then bring the one after). Otherwise which of the two
            # cannot be told, and taking the wrong one loses or doubles a line.
            if not self._distinct:
                self._give_up_out_of_step("copy of the last packet")
                return
            self._emit(Ignored("a repeat of the last packet, sent without waiting", self.state))
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
        if data == self._last_received and self._sent_behind():
            # A copy of the packet we ACKed last with another frame right behind it, in the
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
        if flag == FLAG_OK and self._ahead_of_our_acks("packet"):
            return
        self._after_lost = False
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

    def _nak_corrupt(self, data: bytes) -> None:
        if self._ahead_of_our_acks("damaged frame"):
            return
        self._after_lost = False
        super()._nak_corrupt(data)

    def _ahead_of_our_acks(self, what: str) -> bool:
        """In a multi-packet answer, this frame came with another right behind it, or right
        behind bytes that were no whole frame (a packet that lost its STX or its end), in the
        same read: the controller sent without waiting for our answer, so it took an ACK we
        never sent (a doubled ACK byte) and runs a packet ahead of our ACKs. From there a NAK
        brings the packet after the damaged one, and a frame lost whole goes unnoticed (an FA
        download kept its line count with a line lost and another doubled), so the exchange
        is given up (True)."""
        if self.shape is not Shape.MULTI or self.state not in _RECEIVING:
            return False
        if not (self._after_lost or self._sent_behind()):
            return False
        self._give_up_out_of_step(what)
        return True

    def _give_up_out_of_step(self, what: str) -> None:
        error = LinkRuleError(
            "host",
            self.state.value,
            what,
            "sent without waiting for our answer to the frame before it: the controller "
            "runs ahead of our ACKs",
        )
        self._fail(FailReason.OUT_OF_STEP, str(error), send_rst=True, error=error)

    def receive_data(self, data: bytes, now: float) -> list[LinkEvent]:
        if self.shape is not _MULTI or self.state not in _RECEIVING:
            return Link.receive_data(self, data, now)  # the usual read: nothing to watch
        # Noise or a frame cut short, then a frame, in one read of a multi-packet answer (see
        # _ahead_of_our_acks): the frame came right behind what was lost.
        watch = self.decoder.between_frames
        self._after_lost = watch and _noise_then_frame(data)
        self._watch_read = watch
        try:
            return Link.receive_data(self, data, now)
        finally:
            self._after_lost = self._watch_read = False

    def _cut_short(self) -> None:
        super()._cut_short()
        if self._watch_read:
            # begun in this read (it began between frames): the frame cutting it came right
            # behind it, before our answer to it
            self._after_lost = True

    def _sent_behind(self) -> bool:
        """Did the controller send more right behind the packet in hand, in the same read (a
        packet, a damaged frame or the start of one), so before it could have our answer?"""
        if not self.decoder.between_frames:
            return True
        return any(isinstance(event, Packet | CorruptPacket) for event in self._backlog)

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
        if data == self._last_reply and self._sent_behind():
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
