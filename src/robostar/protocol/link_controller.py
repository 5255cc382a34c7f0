"""The controller's end of the link: requests in, answers out, FB uploads taken."""

from __future__ import annotations

from collections.abc import Sequence

from robostar.errors import LinkRuleError, UsageError
from robostar.protocol.fields import FLAG_END, FLAG_OK
from robostar.protocol.frame import ACK, FrameEvent, encode_packet
from robostar.protocol.link_base import Link, _moves_on
from robostar.protocol.link_events import (
    _COMPLETE,
    LinkEvent,
    PeerMovedOn,
    RequestReceived,
    UploadPacketReceived,
)
from robostar.protocol.link_table import MAX_RESENDS, After, FailReason, Input, Role, State


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
