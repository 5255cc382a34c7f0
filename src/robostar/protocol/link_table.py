"""The link's states, inputs and transition table (h11's ``_state.py`` is the model): what each
state of each role accepts, read state by state, and nothing else.

Every allowed ``(role, state, input)`` is a row of :data:`TRANSITIONS`, naming the handler method
of :class:`~robostar.protocol.link.HostLink` or :class:`~robostar.protocol.link.ControllerLink`
that runs it; a pair that is not there is a rule broken by the peer (RST and
:class:`~robostar.protocol.link.ExchangeFailed`) or, for an application call, a
:class:`~robostar.errors.LinkRuleError` raised at once. ``docs/protocol.md`` draws the table.
"""

from __future__ import annotations

import enum

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
    OUT_OF_STEP = "controller out of step with our ACKs"
    """A multi-packet answer sent without waiting for our ACKs: given up, a read may ask again."""


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

_NOT_BUSY = frozenset((State.IDLE, State.RESYNC))
"""A host link's states outside an exchange (:attr:`Link.busy` is False in them)."""
