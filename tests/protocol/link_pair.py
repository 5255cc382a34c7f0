"""A host and a controller link joined by a perfect in-memory line, and the packets, setups and
helpers the link's test files share.

Both ends are driven with explicit ``now`` values; nothing sleeps. A :class:`Pair` moves bytes
from one end's ``data_to_send()`` into the other's ``receive_data`` until the line is quiet.
``SETUPS`` reaches each state of the transition table from a fresh link by its public interface.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

from robostar.protocol.frame import ACK, NAK, RST, encode_packet
from robostar.protocol.link import (
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    Fence,
    HostLink,
    Link,
    LinkEvent,
    Role,
    State,
)
from robostar.protocol.packets import Shape

ACK_B = bytes((ACK,))
NAK_B = bytes((NAK,))
RST_B = bytes((RST,))
BAD_LRC = bytes.fromhex("02 30 41 03 00")  # LRC should be 0x71

AA = b"\xffAA"
AA_ANSWER = b"0\xb5\x80\x80"
AB = b"\xffAB"
ALARM_1 = b"0E1153 : T/P Emergency       "
ALARM_2 = b"0E1104 : Servo Not Redy      "
END = b"4"
DB = b"\xffDB01"  # servo on, channel 1
DB_FIRST = b"002"  # OK, expected wait 2 s
OK = b"0"
FB = b"\xffFB0      RS.JOB001"
FB_OK = b"\xff0"
LINE_1 = b"MAIN\n"
LINE_2 = b"EOP\n"


def frame(data: bytes) -> bytes:
    return encode_packet(data)


@dataclass
class Pair:
    """A host and a controller joined by a perfect in-memory line, with a clock set by hand."""

    host: HostLink = field(default_factory=HostLink)
    ctl: ControllerLink = field(default_factory=ControllerLink)
    now: float = 0.0
    host_events: list[LinkEvent] = field(default_factory=list)
    ctl_events: list[LinkEvent] = field(default_factory=list)
    to_ctl: list[bytes] = field(default_factory=list)
    to_host: list[bytes] = field(default_factory=list)

    def pump(self) -> None:
        """Carry bytes both ways until neither end has anything to send."""
        while True:
            up = self.host.data_to_send()
            down = self.ctl.data_to_send()
            if not up and not down:
                return
            if up:
                self.to_ctl.append(up)
                self.ctl_events += self.ctl.receive_data(up, self.now)
            if down:
                self.to_host.append(down)
                self.host_events += self.host.receive_data(down, self.now)

    def request(self, data: bytes, shape: Shape = Shape.SINGLE) -> None:
        self.host_events += self.host.send_request(data, shape, self.now)
        self.pump()

    def answer(self, packets: list[bytes], after: After = After.DONE) -> None:
        self.ctl_events += self.ctl.send_answer(packets, after, self.now)
        self.pump()

    def at(self, now: float) -> None:
        """Advance the clock and fire the timers that are due, the controller's first.

        The controller goes first so that a resend due at the very instant of the host's
        deadline reaches the host in time (test_link_resends.py,
        test_a_lost_ack_mid_multi_is_recovered_with_equal_timeouts).
        """
        self.now = now
        self.ctl_events += self.ctl.handle_timeout(now)
        self.pump()
        self.host_events += self.host.handle_timeout(now)
        self.pump()

    def take(self) -> tuple[list[LinkEvent], list[LinkEvent]]:
        events = (self.host_events, self.ctl_events)
        self.host_events, self.ctl_events = [], []
        return events


def answers(events: list[LinkEvent]) -> list[bytes]:
    return [e.data for e in events if isinstance(e, AnswerReceived)]


def failures(events: list[LinkEvent]) -> list[ExchangeFailed]:
    return [e for e in events if isinstance(e, ExchangeFailed)]


def completes(events: list[LinkEvent]) -> int:
    return sum(isinstance(e, ExchangeComplete) for e in events)


# ===============================================================================================
# Each state of the transition table, reached from a fresh link
# ===============================================================================================
T0 = 10.0
"""When the setups below reach their state."""


def _host(shape: Shape, *answers_: bytes, end: bool = False) -> Link:
    host = HostLink()
    request = FB if shape is Shape.UPLOAD else b"\xffXX"
    host.send_request(request, shape, T0)
    for data in answers_:
        host.receive_data(frame(data), T0)
    if end:
        host.send_upload_end(T0)
    host.data_to_send()
    return host


def _ctl(*steps: Callable[[ControllerLink], object]) -> Link:
    ctl = ControllerLink()
    for step in steps:
        step(ctl)
    ctl.data_to_send()
    return ctl


def _ctl_request(ctl: ControllerLink) -> object:
    return ctl.receive_data(frame(AA), T0)


def _ctl_upload_started(ctl: ControllerLink) -> object:
    ctl.receive_data(frame(FB), T0)
    return ctl.send_answer([FB_OK], After.UPLOAD, T0)


def _host_resync() -> Link:
    """A host that timed out waiting for an answer: RST sent, quiet for its resync gap."""
    host = _host(Shape.SINGLE)
    deadline = host.next_deadline()
    assert deadline is not None
    host.handle_timeout(deadline)
    host.data_to_send()
    return host


FENCE = Fence(AA, lambda data: data == AA_ANSWER)
"""A fence for the tests: AA, whose answer is AA_ANSWER."""


def _host_fencing() -> Link:
    """A host whose read timed out: after the quiet gap its next request waits behind a fence
    (sent)."""
    host = HostLink(fences=(FENCE,))
    host.send_request(b"\xffXX", Shape.SINGLE, T0 - 5.0)
    host.handle_timeout(T0 - 3.0)
    host.send_request(b"\xffYY", Shape.SINGLE, T0)
    host.data_to_send()
    return host


SETUPS: dict[tuple[Role, State], Callable[[], Link]] = {
    (Role.HOST, State.IDLE): HostLink,
    (Role.HOST, State.WAIT_ANSWER): lambda: _host(Shape.SINGLE),
    (Role.HOST, State.WAIT_MORE): lambda: _host(Shape.MULTI, ALARM_1),
    (Role.HOST, State.WAIT_SECOND): lambda: _host(Shape.TWO_PHASE, DB_FIRST),
    (Role.HOST, State.UPLOAD_WAIT_REPLY): lambda: _host(Shape.UPLOAD),
    (Role.HOST, State.UPLOAD_READY): lambda: _host(Shape.UPLOAD, FB_OK),
    (Role.HOST, State.UPLOAD_WAIT_ACK): lambda: _host(Shape.UPLOAD, FB_OK, end=True),
    (Role.HOST, State.RESYNC): _host_resync,
    (Role.HOST, State.WAIT_FENCE): _host_fencing,
    (Role.CONTROLLER, State.LISTEN): ControllerLink,
    (Role.CONTROLLER, State.HANDLING): lambda: _ctl(_ctl_request),
    (Role.CONTROLLER, State.WAIT_ACK): lambda: _ctl(
        _ctl_request, lambda c: c.send_answer([AA_ANSWER], After.DONE, T0)
    ),
    (Role.CONTROLLER, State.WORKING): lambda: _ctl(
        _ctl_request,
        lambda c: c.send_answer([DB_FIRST], After.SECOND_PHASE, T0),
        lambda c: c.receive_data(ACK_B, T0),
    ),
    (Role.CONTROLLER, State.UPLOAD_WAIT_PACKET): lambda: _ctl(_ctl_upload_started),
    (Role.CONTROLLER, State.UPLOAD_HANDLING): lambda: _ctl(
        _ctl_upload_started, lambda c: c.receive_data(frame(OK + LINE_1), T0)
    ),
}
"""How to reach each state from a fresh link, by its public interface only."""


# ===============================================================================================
# Shared by several files
# ===============================================================================================
CANCELLED = "RST arrived before this end's turn"
"""The detail of an exchange an RST cancelled during the application's turn."""


def plain(events: list[LinkEvent]) -> list[object]:
    """``events`` with each rule break paired with its error's (role, state, event): exceptions
    compare by identity, so the error is checked by its fields."""
    return [
        (replace(e, error=None), (e.error.role, e.error.state, e.error.event))
        if isinstance(e, ExchangeFailed) and e.error is not None
        else e
        for e in events
    ]


GAP = 0.25
"""HostLink's default resync_gap."""
AC = b"\xffAC01"
BA = b"\xffBA0"
STALE = b"0 stale position"
