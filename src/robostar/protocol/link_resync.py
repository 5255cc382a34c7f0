"""The host's resync rules: after an RST the line must be quiet for a whole gap before the next
request (stops after this end's own abort sooner), and stale packets outside an exchange are
stopped."""

from __future__ import annotations

from robostar.errors import LinkRuleError
from robostar.protocol.frame import ACK, RST, encode_packet
from robostar.protocol.link_events import ExchangeFailed, Ignored
from robostar.protocol.link_host_base import HostLinkBase
from robostar.protocol.link_table import EARLY_CODES, MAX_RESENDS, FailReason, Input, State


class ResyncRules(HostLinkBase):
    """The RESYNC state's handlers, the deferred request, and stray packets when IDLE."""

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
