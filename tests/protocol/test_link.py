"""Tests of the link machine: every transition of the table, and each exchange shape, by hand.

Both ends are driven with explicit ``now`` values; nothing sleeps. A :class:`Pair` moves bytes
from one end's ``data_to_send()`` into the other's ``receive_data`` until the line is quiet.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import pytest

from robostar.errors import LinkRuleError, PacketTooLongError, UsageError
from robostar.protocol.frame import ACK, NAK, RST, encode_packet
from robostar.protocol.link import (
    APP_TURN,
    MAX_BACKLOG,
    MAX_NAKS,
    MAX_RESENDS,
    TRANSITIONS,
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    Fence,
    HostLink,
    Ignored,
    Input,
    Link,
    LinkEvent,
    PeerMovedOn,
    RequestReceived,
    Role,
    State,
    UploadPacketReceived,
    UploadReady,
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
        deadline reaches the host in time (see the race test near the end of this file).
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
# The table: every entry exercised, every missing pair a broken rule
# ===============================================================================================
HOST_APP = frozenset((Input.SEND_REQUEST, Input.SEND_LINE, Input.SEND_END, Input.ABORT))
CTL_APP = frozenset((Input.SEND_ANSWER, Input.ACCEPT_UPLOAD, Input.ABORT))
LINE_INPUTS = frozenset(
    (Input.PACKET, Input.CORRUPT, Input.ACK, Input.NAK, Input.RST, Input.TIMEOUT)
)
APP_INPUTS = {Role.HOST: HOST_APP, Role.CONTROLLER: CTL_APP}
T0 = 10.0


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

PACKET_FOR = {
    State.IDLE: OK,
    State.WAIT_ANSWER: AA_ANSWER,
    State.WAIT_MORE: ALARM_2,
    State.WAIT_SECOND: OK,
    State.UPLOAD_WAIT_REPLY: FB_OK,
    State.UPLOAD_READY: END,  # stale: held, then a broken rule at the next call (see HELD)
    State.UPLOAD_WAIT_ACK: b"\xff2",
    State.RESYNC: AA_ANSWER,
    State.WAIT_FENCE: AA_ANSWER,
    State.LISTEN: AA,
    State.HANDLING: AA,
    State.WAIT_ACK: AB,
    State.WORKING: AB,
    State.UPLOAD_WAIT_PACKET: OK + LINE_2,
    State.UPLOAD_HANDLING: OK + LINE_2,
}
"""A packet that the state's table entry (if any) takes as ordinary traffic."""


def fire(link: Link, what: Input) -> list[LinkEvent]:
    """Give ``link`` one input through its public interface, at time T0 + 0.5."""
    now = T0 + 0.5
    if what is Input.PACKET:
        return link.receive_data(frame(PACKET_FOR[link.state]), now)
    if what is Input.CORRUPT:
        return link.receive_data(BAD_LRC, now)
    if what in (Input.ACK, Input.NAK, Input.RST):
        return link.receive_data({Input.ACK: ACK_B, Input.NAK: NAK_B, Input.RST: RST_B}[what], now)
    if what is Input.TIMEOUT:
        deadline = link.next_deadline()
        assert deadline is not None
        return link.handle_timeout(deadline)
    if what is Input.ABORT:
        return link.abort(now)
    if isinstance(link, HostLink):
        if what is Input.SEND_REQUEST:
            return link.send_request(AA, Shape.SINGLE, now)
        if what is Input.SEND_LINE:
            return link.send_upload_line(LINE_2, now)
        return link.send_upload_end(now)
    assert isinstance(link, ControllerLink)
    if what is Input.SEND_ANSWER:
        after = After.UPLOAD if link.state is State.UPLOAD_HANDLING else After.DONE
        return link.send_answer([FB_OK if after is After.UPLOAD else OK], after, now)
    return link.accept_upload(now)


@pytest.fixture
def fired(monkeypatch: pytest.MonkeyPatch) -> list[tuple[Role, State, Input]]:
    """Every (role, state, input) the links dispatch, recorded through a wrapper."""
    log: list[tuple[Role, State, Input]] = []
    original = Link._fire

    def spy(self: Link, what: Input, data: bytes) -> None:
        log.append((self.role, self.state, what))
        original(self, what, data)

    monkeypatch.setattr(Link, "_fire", spy)
    return log


def test_setups_cover_every_state_of_the_table() -> None:
    in_table = {(role, state) for role, state, _ in TRANSITIONS}
    assert set(SETUPS) == in_table
    assert {state for _, state in in_table} == set(State)
    for (role, state), setup in SETUPS.items():
        link = setup()
        assert (link.role, link.state) == (role, state)


def test_the_table_names_real_handlers_and_each_roles_own_app_calls() -> None:
    for (role, _state, what), name in TRANSITIONS.items():
        cls = HostLink if role is Role.HOST else ControllerLink
        assert callable(getattr(cls, name, None)), name
        if what not in LINE_INPUTS:
            assert what in APP_INPUTS[role]


def test_a_state_without_a_timeout_entry_never_runs_a_timer() -> None:
    for (role, state), setup in SETUPS.items():
        if (role, state, Input.TIMEOUT) not in TRANSITIONS:
            link = setup()
            assert link.next_deadline() is None, state
            assert link.handle_timeout(T0 + 1e6) == []
            assert link.data_to_send() == b""


@pytest.mark.parametrize(
    "key", sorted(TRANSITIONS, key=lambda k: (k[0].value, k[1].value, k[2].value)), ids=str
)
def test_every_table_entry_runs_its_handler(
    key: tuple[Role, State, Input], fired: list[tuple[Role, State, Input]]
) -> None:
    role, state, what = key
    link = SETUPS[(role, state)]()
    fired.clear()
    events = fire(link, what)
    assert fired[0] == key
    assert not [f for f in failures(events) if f.reason is FailReason.RULE]


def _missing() -> list[tuple[Role, State, Input]]:
    return [
        (role, state, what)
        for role, state in SETUPS
        for what in sorted(LINE_INPUTS | APP_INPUTS[role], key=lambda i: i.value)
        if (role, state, what) not in TRANSITIONS and what is not Input.TIMEOUT
    ]


T1 = T0 + 1.0
"""When the application makes its next call after a held input (fire() gives it at T0 + 0.5)."""


def _next_call(link: Link) -> list[LinkEvent]:
    """The application's own next step in each of its turns, at T1."""
    if isinstance(link, HostLink):
        return link.send_upload_line(LINE_2, T1)
    assert isinstance(link, ControllerLink)
    if link.state is State.UPLOAD_HANDLING:
        return link.send_answer([FB_OK], After.UPLOAD, T1)
    return link.send_answer([AA_ANSWER], After.DONE, T1)


ANSWER_F = frame(AA_ANSWER)
REPLY_F = frame(FB_OK)
LINE_F = frame(OK + LINE_2)
CANCELLED = "RST arrived before this end's turn"
HELD: dict[tuple[State, Input], tuple[bytes, list[object], State, float | None]] = {
    # Noise does not show that the host moved on: the controller's answer goes out first and the
    # held input meets it in WAIT_ACK.
    (State.HANDLING, Input.CORRUPT): (ANSWER_F + NAK_B, [], State.WAIT_ACK, T1 + 2.0),
    (State.HANDLING, Input.ACK): (ANSWER_F, [ExchangeComplete()], State.LISTEN, None),
    (State.HANDLING, Input.NAK): (ANSWER_F * 2, [], State.WAIT_ACK, T1 + 2.0),
    # A new request or an RST does: no answer goes out. The request is then a new exchange.
    (State.HANDLING, Input.PACKET): (
        b"",
        [
            ExchangeFailed(FailReason.SUPERSEDED, State.HANDLING, "a new request came first"),
            RequestReceived(AA),
        ],
        State.HANDLING,
        None,
    ),
    (State.HANDLING, Input.RST): (
        b"",
        [ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED)],
        State.LISTEN,
        None,
    ),
    # The upload reply likewise: held noise meets it in UPLOAD_WAIT_PACKET, a held RST cancels
    # it, and a content packet before it is a rule the host broke (RST in place of the reply).
    (State.UPLOAD_HANDLING, Input.CORRUPT): (
        REPLY_F + NAK_B,
        [],
        State.UPLOAD_WAIT_PACKET,
        T1 + 2.0,
    ),
    (State.UPLOAD_HANDLING, Input.ACK): (
        REPLY_F,
        [Ignored("stray input", State.UPLOAD_WAIT_PACKET)],
        State.UPLOAD_WAIT_PACKET,
        T1 + 2.0,
    ),
    (State.UPLOAD_HANDLING, Input.NAK): (REPLY_F * 2, [], State.UPLOAD_WAIT_PACKET, T1 + 2.0),
    (State.UPLOAD_HANDLING, Input.PACKET): (
        RST_B,
        [
            (
                ExchangeFailed(
                    FailReason.RULE,
                    State.UPLOAD_HANDLING,
                    "controller link in state UPLOAD_HANDLING cannot take packet: during our turn",
                ),
                ("controller", "UPLOAD_HANDLING", "packet"),
            )
        ],
        State.LISTEN,
        None,
    ),
    (State.UPLOAD_HANDLING, Input.RST): (
        b"",
        [ExchangeFailed(FailReason.RESET, State.UPLOAD_HANDLING, CANCELLED)],
        State.LISTEN,
        None,
    ),
    # The host's next line goes out before held noise, which meets it in UPLOAD_WAIT_REPLY. The
    # controller sends nothing between its reply and the host's next packet, so a held packet
    # breaks a rule (RST in place of the line, which starts the host's gap) and a held RST ends
    # the upload with nothing sent.
    (State.UPLOAD_READY, Input.CORRUPT): (LINE_F + NAK_B, [], State.UPLOAD_WAIT_REPLY, T1 + 2.0),
    (State.UPLOAD_READY, Input.ACK): (
        LINE_F,
        [Ignored("stray input", State.UPLOAD_WAIT_REPLY)],
        State.UPLOAD_WAIT_REPLY,
        T1 + 2.0,
    ),
    (State.UPLOAD_READY, Input.NAK): (LINE_F * 2, [], State.UPLOAD_WAIT_REPLY, T1 + 2.0),
    (State.UPLOAD_READY, Input.PACKET): (
        RST_B,
        [
            (
                ExchangeFailed(
                    FailReason.RULE,
                    State.UPLOAD_READY,
                    "host link in state UPLOAD_READY cannot take packet: during our turn",
                ),
                ("host", "UPLOAD_READY", "packet"),
            )
        ],
        State.RESYNC,
        T1 + 0.25,
    ),
    (State.UPLOAD_READY, Input.RST): (
        b"",
        [ExchangeFailed(FailReason.RESET, State.UPLOAD_READY, CANCELLED)],
        State.IDLE,
        None,
    ),
}
"""What each held line input does once the application has made its next call (at T1): the
bytes written by then, the events that call returns, the state and the deadline after it."""

REPORTED: dict[tuple[State, Input], list[object]] = {
    (State.HANDLING, Input.PACKET): [PeerMovedOn(State.HANDLING)],
    (State.HANDLING, Input.RST): [PeerMovedOn(State.HANDLING)],
    (State.UPLOAD_HANDLING, Input.PACKET): [PeerMovedOn(State.UPLOAD_HANDLING)],
    (State.UPLOAD_HANDLING, Input.RST): [PeerMovedOn(State.UPLOAD_HANDLING)],
}
"""What held line input reports at once, as it arrives (else nothing): a controller says that
its host moved on, so that its application can drop work nobody waits for."""


def plain(events: list[LinkEvent]) -> list[object]:
    """``events`` with each rule break paired with its error's (role, state, event): exceptions
    compare by identity, so the error is checked by its fields."""
    return [
        (replace(e, error=None), (e.error.role, e.error.state, e.error.event))
        if isinstance(e, ExchangeFailed) and e.error is not None
        else e
        for e in events
    ]


def test_line_input_is_missing_exactly_in_the_applications_turn() -> None:
    assert {State.HANDLING, State.UPLOAD_HANDLING, State.UPLOAD_READY} == APP_TURN
    missing_line_input = {key for key in _missing() if key[2] in LINE_INPUTS}
    assert missing_line_input == {
        (role, state, what)
        for role, state in SETUPS
        if state in APP_TURN
        for what in LINE_INPUTS - {Input.TIMEOUT}
    }
    assert set(HELD) == {(state, what) for _, state, what in missing_line_input}


@pytest.mark.parametrize("key", _missing(), ids=str)
def test_every_missing_pair_breaks_a_rule_or_waits_for_the_application(
    key: tuple[Role, State, Input],
) -> None:
    role, state, what = key
    link = SETUPS[(role, state)]()
    if what in APP_INPUTS[role]:
        with pytest.raises(LinkRuleError) as info:
            fire(link, what)
        assert (info.value.role, info.value.state, info.value.event) == (
            role.value,
            state.value,
            what.value,
        )
        assert link.state is state
        assert link.data_to_send() == b""
        return
    # Line input in the application's turn is held, not a broken rule: nothing happens (but a
    # controller's report that the host moved on)...
    assert fire(link, what) == REPORTED.get((state, what), [])
    assert link.data_to_send() == b""
    assert link.state is state
    assert link.next_deadline() is None
    assert link.busy
    # ...until the application has made its next call, which returns what the input produced.
    written, events, after, deadline = HELD[(state, what)]
    assert plain(_next_call(link)) == events
    assert link.data_to_send() == written
    assert link.state is after
    assert link.next_deadline() == (None if deadline is None else pytest.approx(deadline))


def test_missing_pairs_include_the_rules_the_manual_implies() -> None:
    missing = set(_missing())
    # An upload call outside an upload; an answer nobody asked for; a second request from the
    # host while one is in flight.
    assert (Role.HOST, State.IDLE, Input.SEND_LINE) in missing
    assert (Role.CONTROLLER, State.LISTEN, Input.SEND_ANSWER) in missing
    assert (Role.HOST, State.WAIT_ANSWER, Input.SEND_REQUEST) in missing
    # A request while the controller handles one, a packet where the host owes the next upload
    # line: no table entry, so they wait for the application's next call, and cancel what it
    # would send (see HELD).
    assert (Role.CONTROLLER, State.HANDLING, Input.PACKET) in missing
    assert (Role.HOST, State.UPLOAD_READY, Input.PACKET) in missing


# ===============================================================================================
# Exchange shapes, byte by byte
# ===============================================================================================
def test_single_exchange_bytes() -> None:
    pair = Pair()
    assert pair.host.send_request(AA, Shape.SINGLE, 0.0) == []
    request = pair.host.data_to_send()
    assert request == bytes.fromhex("02 FF 41 41 03 FF")
    assert pair.host.state is State.WAIT_ANSWER
    assert pair.host.next_deadline() == 2.0
    assert pair.ctl.receive_data(request, 0.0) == [RequestReceived(AA)]
    assert pair.ctl.state is State.HANDLING
    assert pair.ctl.next_deadline() is None
    assert pair.ctl.send_answer([AA_ANSWER], After.DONE, 0.1) == []
    answer = pair.ctl.data_to_send()
    assert answer == bytes.fromhex("02 30 B5 80 80 03 85")
    assert pair.ctl.next_deadline() == pytest.approx(2.1)
    assert pair.host.receive_data(answer, 0.1) == [
        AnswerReceived(AA_ANSWER, 0x30, final=True),
        ExchangeComplete(),
    ]
    assert pair.host.data_to_send() == ACK_B
    assert pair.host.idle and pair.host.next_deadline() is None
    assert pair.ctl.receive_data(ACK_B, 0.1) == [ExchangeComplete()]
    assert pair.ctl.idle and pair.ctl.next_deadline() is None
    assert pair.ctl.data_to_send() == b""


def test_a_dummy_byte_before_the_flag_is_accepted() -> None:
    pair = Pair()
    pair.request(b"\xffAD")
    pair.answer([b"\xff0" + b"3N1    V1.0"])
    host, ctl = pair.take()
    assert answers(host) == [b"\xff0" + b"3N1    V1.0"]
    assert host[0] == AnswerReceived(b"\xff03N1    V1.0", 0x30, final=True)
    assert completes(host) == completes(ctl) == 1


def test_multi_exchange_each_packet_after_the_previous_ack() -> None:
    pair = Pair()
    pair.host.send_request(AB, Shape.MULTI, 0.0)
    pair.ctl.receive_data(pair.host.data_to_send(), 0.0)
    pair.ctl.send_answer([ALARM_1, ALARM_2, END], After.DONE, 0.0)
    # Only the first packet goes out until the host ACKs it.
    assert pair.ctl.data_to_send() == frame(ALARM_1)
    assert pair.ctl.data_to_send() == b""
    assert pair.host.receive_data(frame(ALARM_1), 0.1) == [
        AnswerReceived(ALARM_1, 0x30, final=False)
    ]
    assert pair.host.state is State.WAIT_MORE
    # timeout + resend_grace after our ACK: a resend after the controller's own timeout is heard
    assert pair.host.next_deadline() == pytest.approx(0.1 + 2.0 + 0.5)
    assert pair.host.data_to_send() == ACK_B
    assert pair.ctl.receive_data(ACK_B, 0.1) == []
    assert pair.ctl.data_to_send() == frame(ALARM_2)
    assert pair.host.receive_data(frame(ALARM_2), 0.2) == [
        AnswerReceived(ALARM_2, 0x30, final=False)
    ]
    assert pair.host.next_deadline() == pytest.approx(0.2 + 2.0 + 0.5)
    assert pair.ctl.receive_data(pair.host.data_to_send(), 0.2) == []
    assert pair.ctl.data_to_send() == bytes.fromhex("02 34 03 34")
    assert pair.host.receive_data(frame(END), 0.3) == [
        AnswerReceived(END, 0x34, final=True),
        ExchangeComplete(),
    ]
    assert pair.host.data_to_send() == ACK_B  # END is ACKed too
    assert pair.ctl.receive_data(ACK_B, 0.3) == [ExchangeComplete()]
    assert pair.host.idle and pair.ctl.idle


def test_multi_exchange_of_only_an_end_packet() -> None:
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.answer([END])
    host, ctl = pair.take()
    assert answers(host) == [END]
    assert completes(host) == completes(ctl) == 1


def test_two_phase_db_waits_the_expected_time_plus_the_timeout_and_grace() -> None:
    pair = Pair()
    pair.request(DB, Shape.TWO_PHASE)
    pair.now = 0.5
    pair.answer([DB_FIRST], After.SECOND_PHASE)
    host, ctl = pair.take()
    assert host == [AnswerReceived(DB_FIRST, 0x30, final=False)]
    assert ctl == [RequestReceived(DB)]
    assert pair.to_host[-1] == frame(DB_FIRST)
    assert pair.to_ctl[-1] == ACK_B
    assert pair.host.state is State.WAIT_SECOND
    assert pair.host.next_deadline() == pytest.approx(0.5 + 2 + 2.0 + 0.5)
    assert pair.ctl.state is State.WORKING
    assert pair.ctl.next_deadline() is None
    # Nothing happens before the deadline, even past the expected wait plus the reply timeout.
    pair.at(4.99)
    assert pair.take() == ([], [])
    assert pair.host.state is State.WAIT_SECOND
    pair.now = 4.9
    pair.answer([OK])
    host, ctl = pair.take()
    assert host == [AnswerReceived(OK, 0x30, final=True), ExchangeComplete()]
    assert ctl == [ExchangeComplete()]
    assert pair.to_ctl[-1] == ACK_B


def test_two_phase_deadline_passes_without_a_second_answer() -> None:
    pair = Pair()
    pair.request(DB, Shape.TWO_PHASE)
    pair.answer([b"010"], After.SECOND_PHASE)
    assert pair.host.next_deadline() == pytest.approx(10.0 + 2.0 + 0.5)
    pair.take()
    pair.at(12.49)
    assert pair.take() == ([], [])
    pair.at(12.5)
    host, ctl = pair.take()
    assert [f.reason for f in failures(host)] == [FailReason.TIMEOUT]
    assert failures(host)[0].state is State.WAIT_SECOND
    assert [f.reason for f in failures(ctl)] == [FailReason.RESET]
    assert pair.to_ctl[-1] == RST_B
    assert pair.host.state is State.RESYNC
    assert pair.host.next_deadline() == pytest.approx(12.75)
    assert pair.ctl.idle
    pair.at(12.75)
    assert pair.take() == ([], [])
    assert pair.host.idle and pair.host.next_deadline() is None
    assert pair.to_ctl[-1] == RST_B  # the gap's end sends nothing


def test_two_phase_ce_takes_two_bare_flags_even_long_apart() -> None:
    pair = Pair()
    pair.request(b"\xffCE0", Shape.TWO_PHASE)
    pair.answer([OK], After.SECOND_PHASE)
    # CE's first answer has no wait: the deadline is the plain timeout and the resend grace.
    assert pair.host.next_deadline() == pytest.approx(2.0 + 0.5)
    pair.now = 1.5  # well past resend_gap: an equal packet is still the second answer
    pair.answer([OK])
    host, ctl = pair.take()
    assert host == [
        AnswerReceived(OK, 0x30, final=False),
        AnswerReceived(OK, 0x30, final=True),
        ExchangeComplete(),
    ]
    assert completes(ctl) == 1
    assert pair.to_ctl[-2:] == [ACK_B, ACK_B]


def test_two_phase_error_on_the_first_answer_ends_the_exchange() -> None:
    pair = Pair()
    pair.request(DB, Shape.TWO_PHASE)
    pair.answer([b"2"])
    host, ctl = pair.take()
    assert host == [AnswerReceived(b"2", 0x32, final=True), ExchangeComplete()]
    assert completes(ctl) == 1
    assert pair.to_ctl[-1] == ACK_B


def test_fb_upload_lines_end_and_lone_ack() -> None:
    pair = Pair()
    pair.request(FB, Shape.UPLOAD)
    assert pair.host.state is State.UPLOAD_WAIT_REPLY
    pair.answer([FB_OK], After.UPLOAD)
    host, ctl = pair.take()
    assert host == [UploadReady(FB_OK)]
    assert ctl == [RequestReceived(FB)]
    # The host does not ACK upload replies: its next packet answers them.
    assert pair.to_ctl == [frame(FB)]
    assert pair.host.next_deadline() is None
    assert pair.ctl.state is State.UPLOAD_WAIT_PACKET
    for line in (LINE_1, LINE_2):
        pair.host_events += pair.host.send_upload_line(line, pair.now)
        pair.pump()
        assert pair.to_ctl[-1] == frame(b"0" + line)
        host, ctl = pair.take()
        assert ctl == [UploadPacketReceived(line, end=False)]
        assert pair.ctl.state is State.UPLOAD_HANDLING
        pair.answer([FB_OK], After.UPLOAD)
        assert pair.to_host[-1] == bytes.fromhex("02 FF 30 03 CF")
        host, ctl = pair.take()
        assert host == [UploadReady(FB_OK)]
    pair.host_events += pair.host.send_upload_end(pair.now)
    pair.pump()
    assert pair.to_ctl[-1] == bytes.fromhex("02 34 03 34")
    assert pair.host.state is State.UPLOAD_WAIT_ACK
    host, ctl = pair.take()
    assert ctl == [UploadPacketReceived(b"", end=True)]
    pair.ctl_events += pair.ctl.accept_upload(pair.now)
    pair.pump()
    assert pair.to_host[-1] == ACK_B
    host, ctl = pair.take()
    assert host == [ExchangeComplete()]
    assert ctl == [ExchangeComplete()]
    assert pair.host.idle and pair.ctl.idle


def test_fb_refused_at_once() -> None:
    pair = Pair()
    pair.request(FB, Shape.UPLOAD)
    pair.answer([b"\xff2"], After.FINAL)
    host, ctl = pair.take()
    assert host == [AnswerReceived(b"\xff2", 0x32, final=True), ExchangeComplete()]
    assert ctl == [RequestReceived(FB), ExchangeComplete()]
    assert pair.to_ctl == [frame(FB)]  # the error reply ends the upload: no ACK
    assert pair.host.idle and pair.ctl.idle


def test_fb_error_reply_mid_upload() -> None:
    pair = Pair()
    pair.request(FB, Shape.UPLOAD)
    pair.answer([FB_OK], After.UPLOAD)
    pair.host.send_upload_line(LINE_1, 0.0)
    pair.pump()
    pair.take()
    pair.answer([b"\xff1"], After.FINAL)
    host, ctl = pair.take()
    assert host == [AnswerReceived(b"\xff1", 0x31, final=True), ExchangeComplete()]
    assert ctl == [ExchangeComplete()]
    assert pair.host.idle and pair.ctl.idle
    assert pair.to_ctl[-1] == frame(b"0" + LINE_1)


def test_fb_error_reply_in_place_of_the_final_ack() -> None:
    pair = Pair()
    pair.request(FB, Shape.UPLOAD)
    pair.answer([FB_OK], After.UPLOAD)
    pair.host.send_upload_end(0.0)
    pair.pump()
    pair.take()
    pair.answer([b"\xff2"], After.FINAL)
    host, ctl = pair.take()
    assert host == [AnswerReceived(b"\xff2", 0x32, final=True), ExchangeComplete()]
    assert ctl == [ExchangeComplete()]


def test_fb_new_request_mid_upload_supersedes_it() -> None:
    pair = Pair()
    pair.request(FB, Shape.UPLOAD)
    pair.answer([FB_OK], After.UPLOAD)
    pair.take()
    # The host gave up (its RST was lost) and asks something else; the request waits for the
    # end of the host's whole quiet gap, after its own abort too (only a stop goes out after
    # abort_gap, shorter than resync_gap).
    assert pair.host.abort_gap < pair.host.resync_gap
    pair.host.abort(0.0)
    assert pair.host.data_to_send() == RST_B
    pair.take()
    pair.request(AA)
    assert pair.take() == ([], [])
    assert pair.host.state is State.RESYNC
    pair.at(pair.host.abort_gap)
    pair.at(pair.host.resync_gap - 0.0001)
    assert pair.take() == ([], [])
    assert pair.to_ctl == [frame(FB)]
    pair.at(pair.host.resync_gap)
    _, ctl = pair.take()
    assert pair.to_ctl[-1] == frame(AA)
    assert [type(e) for e in ctl] == [ExchangeFailed, RequestReceived]
    assert failures(ctl)[0].reason is FailReason.SUPERSEDED
    assert pair.ctl.state is State.HANDLING


@pytest.mark.parametrize("flag", [0x31, 0x32, 0x33])
@pytest.mark.parametrize("shape", [Shape.SINGLE, Shape.MULTI, Shape.TWO_PHASE])
def test_error_answers_are_acked_and_end_the_exchange(flag: int, shape: Shape) -> None:
    pair = Pair()
    pair.request(b"\xffCC0", shape)
    error = bytes((flag,))
    pair.answer([error])
    host, ctl = pair.take()
    assert host == [AnswerReceived(error, flag, final=True), ExchangeComplete()]
    assert completes(ctl) == 1
    assert pair.to_ctl[-1] == ACK_B


def test_error_flag_mid_multi_ends_it() -> None:
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.answer([ALARM_1, b"2"])
    host, ctl = pair.take()
    assert answers(host) == [ALARM_1, b"2"]
    assert host[-2] == AnswerReceived(b"2", 0x32, final=True)
    assert completes(host) == completes(ctl) == 1
    assert pair.to_ctl[1:] == [ACK_B, ACK_B]


# ===============================================================================================
# NAK, corrupt packets, RST
# ===============================================================================================
def test_host_resends_the_same_request_bytes_on_nak() -> None:
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    first = host.data_to_send()
    assert host.receive_data(NAK_B, 1.5) == []
    assert host.data_to_send() == first
    assert host.next_deadline() == pytest.approx(3.5)  # the timer restarts with the resend


def test_controller_resends_the_same_answer_bytes_on_nak() -> None:
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.ctl.send_answer([ALARM_1, END], After.DONE, 0.0)
    sent = pair.ctl.data_to_send()
    assert pair.ctl.receive_data(NAK_B, 0.2) == []
    assert pair.ctl.data_to_send() == sent == frame(ALARM_1)
    assert pair.ctl.next_deadline() == pytest.approx(2.2)


def test_host_resends_an_upload_line_and_the_end_on_nak() -> None:
    pair = Pair()
    pair.request(FB, Shape.UPLOAD)
    pair.answer([FB_OK], After.UPLOAD)
    pair.host.send_upload_line(LINE_1, 0.0)
    line = pair.host.data_to_send()
    pair.host.receive_data(NAK_B, 0.1)
    assert pair.host.data_to_send() == line == frame(b"0" + LINE_1)
    pair.host.receive_data(frame(FB_OK), 0.2)
    pair.host.send_upload_end(0.2)
    end = pair.host.data_to_send()
    pair.host.receive_data(NAK_B, 0.3)
    assert pair.host.data_to_send() == end == frame(END)


def test_controller_resends_an_upload_reply_on_nak() -> None:
    ctl = ControllerLink()
    ctl.receive_data(frame(FB), 0.0)
    ctl.send_answer([FB_OK], After.UPLOAD, 0.0)
    reply = ctl.data_to_send()
    ctl.receive_data(NAK_B, 0.1)
    assert ctl.data_to_send() == reply


def test_three_naks_are_resends_and_the_fourth_is_rst() -> None:
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    first = host.data_to_send()
    for i in range(MAX_NAKS):
        assert host.receive_data(NAK_B, 0.1 * (i + 1)) == []
        assert host.data_to_send() == first
    events = host.receive_data(NAK_B, 0.4)
    assert host.data_to_send() == RST_B
    [failed] = failures(events)
    assert (failed.reason, failed.state) == (FailReason.NAK_LIMIT, State.WAIT_ANSWER)
    assert host.state is State.RESYNC and host.next_deadline() == pytest.approx(0.65)
    assert host.handle_timeout(0.65) == []
    assert host.data_to_send() == b""
    assert host.idle and host.next_deadline() is None


def test_controller_naks_are_counted_per_packet() -> None:
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.ctl.send_answer([ALARM_1, ALARM_2, END], After.DONE, 0.0)
    pair.ctl.data_to_send()
    for _ in range(MAX_NAKS):
        pair.ctl.receive_data(NAK_B, 0.1)
        assert pair.ctl.data_to_send() == frame(ALARM_1)
    pair.ctl.receive_data(ACK_B, 0.2)
    assert pair.ctl.data_to_send() == frame(ALARM_2)
    # A fresh packet starts a fresh count: three more NAKs are still resends.
    for _ in range(MAX_NAKS):
        pair.ctl.receive_data(NAK_B, 0.3)
        assert pair.ctl.data_to_send() == frame(ALARM_2)
    events = pair.ctl.receive_data(NAK_B, 0.4)
    assert pair.ctl.data_to_send() == RST_B
    assert [f.reason for f in failures(events)] == [FailReason.NAK_LIMIT]
    assert pair.ctl.idle


def test_corrupt_answers_are_naked_three_times_then_rst() -> None:
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    host.data_to_send()
    for i in range(MAX_NAKS):
        assert host.receive_data(BAD_LRC, 0.5 * (i + 1)) == []
        assert host.data_to_send() == NAK_B
        assert host.next_deadline() == pytest.approx(0.5 * (i + 1) + 2.0)
    events = host.receive_data(BAD_LRC, 2.0)
    assert host.data_to_send() == RST_B
    [failed] = failures(events)
    assert (failed.reason, failed.state) == (FailReason.NAK_LIMIT, State.WAIT_ANSWER)
    assert host.state is State.RESYNC and host.next_deadline() == pytest.approx(2.25)


def test_a_good_packet_resets_the_corrupt_count() -> None:
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.ctl.send_answer([ALARM_1, ALARM_2, END], After.DONE, 0.0)
    pair.ctl.data_to_send()
    for _ in range(MAX_NAKS):
        pair.host.receive_data(BAD_LRC, 0.1)
        assert pair.host.data_to_send() == NAK_B
    pair.host.receive_data(frame(ALARM_1), 0.1)
    assert pair.host.data_to_send() == ACK_B
    for _ in range(MAX_NAKS):
        pair.host.receive_data(BAD_LRC, 0.2)
        assert pair.host.data_to_send() == NAK_B
    assert pair.host.state is State.WAIT_MORE


def test_controller_naks_corrupt_requests_then_rsts_the_fourth() -> None:
    ctl = ControllerLink()
    for _ in range(MAX_NAKS):
        assert ctl.receive_data(BAD_LRC, 0.0) == []
        assert ctl.data_to_send() == NAK_B
    events = ctl.receive_data(BAD_LRC, 0.0)
    assert ctl.data_to_send() == RST_B
    assert events == [Ignored("corrupt packet: RST after 3 NAKs", State.LISTEN)]
    assert ctl.idle
    # The count starts again after the RST.
    ctl.receive_data(BAD_LRC, 0.0)
    assert ctl.data_to_send() == NAK_B


def test_controller_naks_a_corrupt_ack_wait_packet_and_keeps_waiting() -> None:
    pair = Pair()
    pair.request(AA)
    pair.ctl.send_answer([AA_ANSWER], After.DONE, 0.0)
    pair.ctl.data_to_send()
    pair.ctl.receive_data(BAD_LRC, 1.0)
    assert pair.ctl.data_to_send() == NAK_B
    assert pair.ctl.state is State.WAIT_ACK
    assert pair.ctl.next_deadline() == pytest.approx(3.0)


def test_an_overlong_frame_is_naked_like_a_bad_lrc() -> None:
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    host.data_to_send()
    assert host.receive_data(b"\x02" + b"A" * 260 + b"\x03\x41", 0.2) == []
    assert host.data_to_send() == NAK_B
    assert host.state is State.WAIT_ANSWER


def test_a_frame_cut_short_by_a_new_stx_is_not_naked() -> None:
    # The new STX starts the next frame; a NAK would make the controller resend a packet the
    # host may take whole a moment later.
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    host.data_to_send()
    events = host.receive_data(bytes.fromhex("02 30 B5") + frame(AA_ANSWER), 0.1)
    assert events == [
        Ignored("frame cut short by a new STX", State.WAIT_ANSWER),
        AnswerReceived(AA_ANSWER, 0x30, final=True),
        ExchangeComplete(),
    ]
    assert host.data_to_send() == ACK_B


def test_a_doubled_stx_does_not_run_a_request_twice() -> None:
    # Regression: a duplicated STX used to be NAKed, so the host resent a request the
    # controller had already taken whole, and a state-changing command ran twice.
    pair = Pair()
    pair.host.send_request(b"\xffBA0", Shape.SINGLE, 0.0)
    request = pair.host.data_to_send()
    pair.ctl_events += pair.ctl.receive_data(request[:1] + request, 0.0)
    assert pair.ctl.data_to_send() == b""
    pair.answer([OK])
    host, ctl = pair.take()
    assert [e for e in ctl if isinstance(e, RequestReceived)] == [RequestReceived(b"\xffBA0")]
    assert answers(host) == [OK]
    assert pair.to_ctl == [ACK_B]


def test_truncated_frames_do_not_count_towards_the_rst() -> None:
    ctl = ControllerLink()
    for _ in range(MAX_NAKS + 2):
        ctl.receive_data(bytes.fromhex("02 30 31"), 0.0)
    ctl.receive_data(frame(AA), 0.0)
    assert ctl.data_to_send() == b""
    assert ctl.state is State.HANDLING


def test_host_abort_sends_rst_and_the_controller_returns_to_listen() -> None:
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.ctl.send_answer([ALARM_1, END], After.DONE, 0.0)
    events = pair.host.abort(0.1)
    assert [(f.reason, f.state) for f in failures(events)] == [
        (FailReason.ABORTED, State.WAIT_ANSWER)
    ]
    assert pair.host.data_to_send() == RST_B
    assert pair.host.state is State.RESYNC
    # The whole quiet gap (AB is no stop): an answer may still be on its way.
    assert pair.host.next_deadline() == pytest.approx(0.1 + pair.host.resync_gap)
    ctl_events = pair.ctl.receive_data(RST_B, 0.1)
    assert [(f.reason, f.state) for f in failures(ctl_events)] == [
        (FailReason.RESET, State.WAIT_ACK)
    ]
    assert pair.ctl.idle and pair.ctl.next_deadline() is None
    assert pair.ctl.data_to_send() == frame(ALARM_1)  # sent before the RST; nothing after


def test_controller_abort_resets_the_host() -> None:
    pair = Pair()
    pair.request(DB, Shape.TWO_PHASE)
    pair.answer([DB_FIRST], After.SECOND_PHASE)
    pair.take()
    pair.ctl_events += pair.ctl.abort(1.0)
    pair.pump()
    host, ctl = pair.take()
    assert [(f.reason, f.state) for f in failures(ctl)] == [(FailReason.ABORTED, State.WORKING)]
    assert [(f.reason, f.state) for f in failures(host)] == [(FailReason.RESET, State.WAIT_SECOND)]
    assert pair.host.idle and pair.ctl.idle
    # Both ends take the next exchange normally.
    pair.request(AA)
    pair.answer([AA_ANSWER])
    host, ctl = pair.take()
    assert answers(host) == [AA_ANSWER]
    assert completes(host) == completes(ctl) == 1


def test_rst_inside_an_unfinished_frame_is_data() -> None:
    # Between STX and ETX every byte is data, so a frame whose end was lost swallows a RST; the
    # next STX ends that frame (ignored, not NAKed) and the link carries on.
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    host.data_to_send()
    assert host.receive_data(bytes.fromhex("02 30 B5") + RST_B, 0.1) == []
    assert host.state is State.WAIT_ANSWER
    assert host.decoder.pending == 3
    events = host.receive_data(frame(AA_ANSWER), 0.2)
    assert answers(events) == [AA_ANSWER]
    assert completes(events) == 1


def test_abort_while_idle_does_nothing() -> None:
    for link in (HostLink(), ControllerLink()):
        assert link.abort(0.0) == [Ignored("stray input", link.state)]
        assert link.data_to_send() == b""


# ===============================================================================================
# Timeouts
# ===============================================================================================
def test_host_reply_timeout_sends_rst_and_nothing_before_the_deadline() -> None:
    host = HostLink(timeout=1.5)
    host.send_request(AA, Shape.SINGLE, 10.0)
    host.data_to_send()
    assert host.next_deadline() == 11.5
    for now in (10.0, 10.7, 11.4999):
        assert host.handle_timeout(now) == []
        assert host.data_to_send() == b""
        assert host.state is State.WAIT_ANSWER
    events = host.handle_timeout(11.5)
    assert host.data_to_send() == RST_B
    [failed] = failures(events)
    assert (failed.reason, failed.state) == (FailReason.TIMEOUT, State.WAIT_ANSWER)
    assert "1.5 s" in failed.detail
    assert failed.error is None
    assert host.state is State.RESYNC and host.next_deadline() == 11.75
    assert host.handle_timeout(11.7499) == []
    assert host.state is State.RESYNC
    assert host.handle_timeout(11.75) == []
    assert host.data_to_send() == b""
    assert host.idle and host.next_deadline() is None
    assert host.handle_timeout(100.0) == []


def test_host_timeout_mid_multi_resets_the_controller() -> None:
    pair = Pair(ctl=ControllerLink(timeout=5.0))
    pair.request(AB, Shape.MULTI)
    pair.ctl.send_answer([ALARM_1, ALARM_2, END], After.DONE, 0.0)
    pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    pair.ctl.receive_data(pair.host.data_to_send(), 0.0)
    assert pair.ctl.data_to_send() == frame(ALARM_2)  # lost on the line
    pair.take()
    assert pair.host.next_deadline() == pytest.approx(2.5)
    pair.at(2.49)
    assert pair.take() == ([], [])
    pair.at(2.5)
    host, ctl = pair.take()
    assert [(f.reason, f.state) for f in failures(host)] == [(FailReason.TIMEOUT, State.WAIT_MORE)]
    assert [(f.reason, f.state) for f in failures(ctl)] == [(FailReason.RESET, State.WAIT_ACK)]
    assert pair.to_ctl[-1] == RST_B
    assert pair.ctl.next_deadline() is None
    assert pair.host.state is State.RESYNC
    assert pair.host.next_deadline() == pytest.approx(2.75)


def test_upload_wait_ack_times_out() -> None:
    pair = Pair()
    pair.request(FB, Shape.UPLOAD)
    pair.answer([FB_OK], After.UPLOAD)
    pair.host.send_upload_end(5.0)
    pair.host.data_to_send()  # the end packet is lost
    assert pair.host.next_deadline() == 7.0
    events = pair.host.handle_timeout(7.0)
    assert [(f.reason, f.state) for f in failures(events)] == [
        (FailReason.TIMEOUT, State.UPLOAD_WAIT_ACK)
    ]
    assert pair.host.data_to_send() == RST_B
    assert pair.host.state is State.RESYNC
    assert pair.host.next_deadline() == pytest.approx(7.25)


def test_controller_upload_stall_drops_the_exchange_without_rst() -> None:
    ctl = ControllerLink()
    ctl.receive_data(frame(FB), 0.0)
    ctl.send_answer([FB_OK], After.UPLOAD, 0.0)
    ctl.data_to_send()
    assert ctl.next_deadline() == 2.0
    assert ctl.handle_timeout(1.99) == []
    events = ctl.handle_timeout(2.0)
    assert [(f.reason, f.state) for f in failures(events)] == [
        (FailReason.TIMEOUT, State.UPLOAD_WAIT_PACKET)
    ]
    assert ctl.data_to_send() == b""
    assert ctl.idle


def test_controller_resends_an_unacked_answer_three_times_then_drops_it() -> None:
    ctl = ControllerLink(timeout=2.0)
    ctl.receive_data(frame(AA), 0.0)
    ctl.send_answer([AA_ANSWER], After.DONE, 0.0)
    answer = ctl.data_to_send()
    for i in range(1, MAX_RESENDS + 1):
        assert ctl.handle_timeout(2.0 * i - 0.01) == []
        assert ctl.data_to_send() == b""
        assert ctl.handle_timeout(2.0 * i) == []
        assert ctl.data_to_send() == answer
        assert ctl.next_deadline() == pytest.approx(2.0 * (i + 1))
    events = ctl.handle_timeout(2.0 * (MAX_RESENDS + 1))
    assert ctl.data_to_send() == b""  # dropped quietly: no RST, the host times out on its own
    [failed] = failures(events)
    assert (failed.reason, failed.state) == (FailReason.TIMEOUT, State.WAIT_ACK)
    assert ctl.idle and ctl.next_deadline() is None


def test_max_resends_is_configurable() -> None:
    ctl = ControllerLink(max_resends=0)
    ctl.receive_data(frame(AA), 0.0)
    ctl.send_answer([AA_ANSWER], After.DONE, 0.0)
    ctl.data_to_send()
    assert [f.reason for f in failures(ctl.handle_timeout(2.0))] == [FailReason.TIMEOUT]


def test_a_nak_resend_does_not_count_against_the_timeout_resends() -> None:
    ctl = ControllerLink()
    ctl.receive_data(frame(AA), 0.0)
    ctl.send_answer([AA_ANSWER], After.DONE, 0.0)
    answer = ctl.data_to_send()
    ctl.receive_data(NAK_B, 0.5)
    assert ctl.data_to_send() == answer
    for i in range(MAX_RESENDS):
        ctl.handle_timeout(ctl.next_deadline() or 0.0)
        assert ctl.data_to_send() == answer, i
    assert failures(ctl.handle_timeout(ctl.next_deadline() or 0.0))


# ===============================================================================================
# Lost ACKs, resends and supersession
# ===============================================================================================
def test_lost_ack_of_a_single_answer_is_acked_again_while_idle() -> None:
    pair = Pair()
    pair.request(AA)
    pair.ctl.send_answer([AA_ANSWER], After.DONE, 0.0)
    pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    assert pair.host.data_to_send() == ACK_B  # lost on the line
    assert pair.host.idle
    pair.take()
    pair.at(2.0)  # the controller resends; the idle host knows the packet and ACKs it again
    host, ctl = pair.take()
    assert host == [Ignored("resent answer outside an exchange (ACKed again)", State.IDLE)]
    assert ctl == [ExchangeComplete()]
    assert pair.to_host[-1] == frame(AA_ANSWER)
    assert pair.to_ctl[-1] == ACK_B
    assert pair.host.idle and pair.ctl.idle


def test_lost_ack_mid_multi_is_acked_again_and_not_delivered_twice() -> None:
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.ctl.send_answer([ALARM_1, ALARM_2, END], After.DONE, 0.0)
    pair.host_events += pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    assert pair.host.data_to_send() == ACK_B  # lost
    pair.at(2.0)
    # Resent ALARM_1 was re-ACKed, so ALARM_2 and END follow.
    host, ctl = pair.take()
    assert answers(host) == [ALARM_1, ALARM_2, END]
    assert Ignored("resent answer (ACKed again)", State.WAIT_MORE) in host
    assert completes(host) == completes(ctl) == 1


def test_an_equal_packet_sooner_than_resend_gap_is_new_data() -> None:
    # Two equal alarms in a row: the second comes right after our ACK, so it is not a resend.
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.answer([ALARM_1, ALARM_1, END])
    host, _ = pair.take()
    assert answers(host) == [ALARM_1, ALARM_1, END]


def test_a_copy_is_a_resend_only_once_the_controller_could_resend() -> None:
    # The controller resends after its own timeout (peer_resend_after): an equal packet sooner
    # than 90 % of it after our ACK is new data, later it is the resend of a lost ACK's packet.
    host = HostLink(peer_resend_after=1.0)
    host.send_request(AB, Shape.MULTI, 0.0)
    host.data_to_send()
    host.receive_data(frame(ALARM_1), 1.0)
    events = host.receive_data(frame(ALARM_1), 1.0 + 0.8999)
    assert answers(events) == [ALARM_1]
    events = host.receive_data(frame(ALARM_1), 1.8999 + 0.9001)
    assert answers(events) == []
    assert host.data_to_send() == ACK_B * 3


def test_peer_resend_after_defaults_to_the_reply_timeout() -> None:
    assert HostLink(timeout=1.5).peer_resend_after == 1.5


def test_lost_ack_of_db_first_answer_keeps_the_second_phase_deadline() -> None:
    # DB announces 5 s of work. The host's ACK of that first answer is lost, so the controller
    # resends it after its 2 s timeout; the host ACKs the copy again but must still wait for
    # the second answer until 5 s + timeout + grace after the first answer, not 2.5 s after the
    # copy.
    pair = Pair()
    pair.request(DB, Shape.TWO_PHASE)
    pair.ctl.send_answer([b"005"], After.SECOND_PHASE, 0.0)
    pair.host_events += pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    assert pair.host.next_deadline() == pytest.approx(7.5)
    assert pair.host.data_to_send() == ACK_B  # lost
    pair.at(2.0)
    host, ctl = pair.take()
    assert Ignored("resent answer (ACKed again)", State.WAIT_SECOND) in host
    assert answers(host) == [b"005"]
    assert pair.ctl.state is State.WORKING
    assert pair.host.next_deadline() == pytest.approx(7.5)
    pair.at(5.0)
    assert pair.take() == ([], [])
    pair.now = 5.0
    pair.answer([OK])
    host, ctl = pair.take()
    assert answers(host) == [OK]
    assert completes(host) == completes(ctl) == 1


def _answered_then(next_request_at: float) -> HostLink:
    """A host whose AA was answered (and ACKed) at 0.1, with BA sent at ``next_request_at``."""
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    assert answers(host.receive_data(frame(AA_ANSWER), 0.1)) == [AA_ANSWER]
    assert host.send_request(BA, Shape.SINGLE, next_request_at) == []
    assert host.data_to_send() == frame(AA) + ACK_B + frame(BA)
    return host


def test_a_late_copy_of_the_previous_answer_is_acked_again_not_taken_as_the_next() -> None:
    # BA went out right behind our ACK of AA's answer; a copy of that answer arriving late is
    # the controller resending it after its own timeout (the ACK was lost), not BA's answer.
    host = _answered_then(0.1)
    assert host.receive_data(frame(AA_ANSWER), 2.1) == [
        Ignored("resent answer (ACKed again)", State.WAIT_ANSWER)
    ]
    assert host.data_to_send() == ACK_B
    assert host.state is State.WAIT_ANSWER
    assert host.next_deadline() == pytest.approx(2.1 + 2.0 + 0.5)
    assert host.receive_data(frame(OK), 2.2) == [
        AnswerReceived(OK, 0x30, final=True),
        ExchangeComplete(),
    ]


@pytest.mark.parametrize(
    ("request_at", "copy_at"),
    [(0.1, 0.3499), (0.5, 2.1)],
    ids=["the copy comes at once", "the request went out later"],
)
def test_an_equal_answer_is_the_next_requests_answer(request_at: float, copy_at: float) -> None:
    host = _answered_then(request_at)
    assert host.receive_data(frame(AA_ANSWER), copy_at) == [
        AnswerReceived(AA_ANSWER, 0x30, final=True),
        ExchangeComplete(),
    ]
    assert host.data_to_send() == ACK_B
    assert host.idle


def test_new_request_while_controller_waits_for_ack_completes_the_old_exchange() -> None:
    pair = Pair()
    pair.request(AA)
    pair.ctl.send_answer([AA_ANSWER], After.DONE, 0.0)
    pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    pair.host.data_to_send()  # ACK lost
    pair.take()
    pair.now = 0.1
    pair.request(b"\xffAC01")
    _, ctl = pair.take()
    # The new request shows the host got the answer: the old exchange is done.
    assert ctl == [ExchangeComplete(), RequestReceived(b"\xffAC01")]
    assert pair.ctl.state is State.HANDLING
    assert pair.ctl.next_deadline() is None


def test_new_request_mid_multi_supersedes_the_old_exchange() -> None:
    # A slow controller (5 s): its first resend is not due before the host's next request.
    pair = Pair(ctl=ControllerLink(timeout=5.0))
    pair.request(AB, Shape.MULTI)
    pair.ctl.send_answer([ALARM_1, END], After.DONE, 0.0)
    pair.ctl.data_to_send()  # lost
    pair.take()
    pair.host_events += pair.host.handle_timeout(2.0)  # the host gives up; its RST is lost
    assert pair.host.data_to_send() == RST_B
    assert pair.host.state is State.RESYNC
    pair.take()
    pair.now = 2.0
    pair.request(AA)  # deferred to the end of the host's quiet gap
    assert pair.take() == ([], [])
    pair.at(2.25)
    host, ctl = pair.take()
    assert host == []
    assert pair.to_ctl[-1] == frame(AA)
    assert [type(e) for e in ctl] == [ExchangeFailed, RequestReceived]
    assert (failures(ctl)[0].reason, failures(ctl)[0].state) == (
        FailReason.SUPERSEDED,
        State.WAIT_ACK,
    )
    pair.answer([AA_ANSWER])
    host, ctl = pair.take()
    assert answers(host) == [AA_ANSWER]


def test_new_request_while_working_supersedes_the_second_phase() -> None:
    pair = Pair()
    pair.request(DB, Shape.TWO_PHASE)
    pair.answer([DB_FIRST], After.SECOND_PHASE)
    pair.host.abort(1.0)
    assert pair.host.data_to_send() == RST_B  # lost
    pair.take()
    pair.now = 1.0
    pair.request(AA)  # deferred to the end of the host's whole quiet gap after its abort
    assert pair.take() == ([], [])
    pair.at(1.0 + pair.host.abort_gap)
    pair.at(1.0 + pair.host.resync_gap - 0.0001)
    assert pair.take() == ([], [])
    pair.at(1.0 + pair.host.resync_gap)
    _, ctl = pair.take()
    assert pair.to_ctl[-1] == frame(AA)
    assert [(f.reason, f.state) for f in failures(ctl)] == [(FailReason.SUPERSEDED, State.WORKING)]
    assert ctl[-1] == RequestReceived(AA)


def test_a_non_request_packet_while_waiting_for_ack_breaks_a_rule() -> None:
    pair = Pair()
    pair.request(AA)
    pair.ctl.send_answer([AA_ANSWER], After.DONE, 0.0)
    pair.ctl.data_to_send()
    events = pair.ctl.receive_data(frame(OK), 0.1)
    [failed] = failures(events)
    assert failed.reason is FailReason.RULE
    assert isinstance(failed.error, LinkRuleError)
    assert failed.error.state == "WAIT_ACK"
    assert pair.ctl.data_to_send() == RST_B


def test_a_stale_packet_while_host_idle_is_answered_with_rst() -> None:
    host = HostLink()
    events = host.receive_data(frame(b"0stale"), 3.0)
    assert events == [Ignored("stale packet outside an exchange (RST)", State.IDLE)]
    assert host.data_to_send() == RST_B
    # The controller sends nothing more before it takes the RST: no gap is needed.
    assert host.idle and host.next_deadline() is None
    assert host.send_request(AA, Shape.SINGLE, 3.1) == []
    assert host.data_to_send() == frame(AA)


def test_only_a_copy_of_the_last_acked_answer_is_acked_again_while_idle() -> None:
    host = HostLink()
    host.send_request(AB, Shape.MULTI, 0.0)
    host.data_to_send()
    host.receive_data(frame(ALARM_1) + frame(END), 0.1)
    assert host.data_to_send() == ACK_B * 2
    assert host.idle
    # An earlier packet of the same exchange is not the one whose ACK may have been lost.
    assert host.receive_data(frame(ALARM_1), 2.1) == [
        Ignored("stale packet outside an exchange (RST)", State.IDLE)
    ]
    assert host.data_to_send() == RST_B
    assert host.receive_data(frame(END), 2.2) == [
        Ignored("resent answer outside an exchange (ACKed again)", State.IDLE)
    ]
    assert host.data_to_send() == ACK_B
    assert host.idle and host.next_deadline() is None


def test_an_abandoned_multi_answer_is_stopped_by_the_idle_host() -> None:
    # A slow controller (5 s). The host's ACK of ALARM_1 is lost; the host gives up at 2.5 and
    # its RST is lost too, so the controller resends ALARM_1 at 5.0 to an idle host. The host
    # reset that exchange itself, so nothing of it is ACKed again: the copy is stopped with RST
    # at once instead of the host ACKing the whole stream to its end.
    pair = Pair(ctl=ControllerLink(timeout=5.0))
    pair.request(AB, Shape.MULTI)
    pair.ctl.send_answer([ALARM_1, ALARM_2, END], After.DONE, 0.0)
    pair.host_events += pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    assert pair.host.data_to_send() == ACK_B  # lost
    assert pair.host.next_deadline() == pytest.approx(2.5)
    events = pair.host.handle_timeout(2.5)
    assert [(f.reason, f.state) for f in failures(events)] == [
        (FailReason.TIMEOUT, State.WAIT_MORE)
    ]
    assert pair.host.data_to_send() == RST_B  # lost
    pair.take()
    pair.at(2.75)
    assert pair.take() == ([], [])
    assert pair.host.idle and pair.ctl.state is State.WAIT_ACK
    pair.at(5.0)
    host, ctl = pair.take()
    assert host == [Ignored("stale packet outside an exchange (RST)", State.IDLE)]
    assert ctl == [ExchangeFailed(FailReason.RESET, State.WAIT_ACK, "RST received")]
    assert pair.to_host == [frame(ALARM_1)]  # the resend, stopped: ALARM_2 never comes
    assert pair.to_ctl[-1:] == [RST_B]
    assert pair.host.idle and pair.ctl.idle
    assert pair.ctl.next_deadline() is None


def test_stray_control_bytes_while_idle_are_ignored() -> None:
    for link in (HostLink(), ControllerLink()):
        events = link.receive_data(ACK_B + NAK_B + RST_B, 0.0)
        assert events == [Ignored("stray input", link.state)] * 3
        assert link.data_to_send() == b""
        assert link.idle


# ===============================================================================================
# Rules the peer breaks, and the application's own mistakes
# ===============================================================================================
def test_an_end_packet_in_a_single_exchange_breaks_a_rule() -> None:
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    host.data_to_send()
    events = host.receive_data(frame(END), 0.1)
    assert host.data_to_send() == ACK_B + RST_B  # the packet was intact; its place is wrong
    assert host.state is State.RESYNC and host.next_deadline() == pytest.approx(0.35)
    [failed] = failures(events)
    assert failed.reason is FailReason.RULE
    assert isinstance(failed.error, LinkRuleError)
    assert (failed.error.state, failed.error.event) == ("WAIT_ANSWER", "END packet")
    assert answers(events) == []


@pytest.mark.parametrize("data", [b"9", b"", b"\xff", b"A0"])
def test_an_answer_with_no_known_flag_breaks_a_rule(data: bytes) -> None:
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    host.data_to_send()
    events = host.receive_data(frame(data), 0.1)
    assert host.data_to_send() == RST_B
    assert host.state is State.RESYNC and host.next_deadline() == pytest.approx(0.35)
    [failed] = failures(events)
    assert failed.reason is FailReason.RULE
    assert isinstance(failed.error, LinkRuleError)
    assert failed.error.state == "WAIT_ANSWER"


@pytest.mark.parametrize("data", [b"4", b"9", b""])
def test_an_upload_reply_that_is_neither_ok_nor_error_breaks_a_rule(data: bytes) -> None:
    host = HostLink()
    host.send_request(FB, Shape.UPLOAD, 0.0)
    host.data_to_send()
    events = host.receive_data(frame(data), 0.1)
    assert host.data_to_send() == RST_B
    assert [f.reason for f in failures(events)] == [FailReason.RULE]


def test_an_ok_packet_in_place_of_the_upload_ack_breaks_a_rule() -> None:
    host = HostLink()
    host.send_request(FB, Shape.UPLOAD, 0.0)
    host.receive_data(frame(FB_OK), 0.0)
    host.send_upload_end(0.0)
    host.data_to_send()
    events = host.receive_data(frame(FB_OK), 0.1)
    assert host.data_to_send() == RST_B
    assert [f.reason for f in failures(events)] == [FailReason.RULE]


@pytest.mark.parametrize("data", [b"5abc", b"1", END + b"x"])
def test_an_upload_packet_the_controller_cannot_read_breaks_a_rule(data: bytes) -> None:
    ctl = ControllerLink()
    ctl.receive_data(frame(FB), 0.0)
    ctl.send_answer([FB_OK], After.UPLOAD, 0.0)
    ctl.data_to_send()
    events = ctl.receive_data(frame(data), 0.1)
    assert ctl.data_to_send() == RST_B
    [failed] = failures(events)
    assert (failed.reason, failed.state) == (FailReason.RULE, State.UPLOAD_WAIT_PACKET)


def test_app_calls_in_the_wrong_state_raise_and_change_nothing() -> None:
    host = HostLink()
    with pytest.raises(LinkRuleError) as info:
        host.send_upload_line(LINE_1, 0.0)
    assert (info.value.state, info.value.event) == ("IDLE", "send_upload_line")
    host.send_request(AA, Shape.SINGLE, 0.0)
    sent = host.data_to_send()
    with pytest.raises(LinkRuleError) as info:
        host.send_request(AB, Shape.SINGLE, 0.5)
    assert (info.value.state, info.value.event) == ("WAIT_ANSWER", "send_request")
    assert host.data_to_send() == b""
    assert host.next_deadline() == 2.0
    assert host.receive_data(NAK_B, 0.6) == []
    assert host.data_to_send() == sent  # the first request is still the one in flight
    ctl = ControllerLink()
    with pytest.raises(LinkRuleError) as info:
        ctl.accept_upload(0.0)
    assert (info.value.role, info.value.state) == ("controller", "LISTEN")


def test_send_answer_needs_a_packet() -> None:
    ctl = ControllerLink()
    ctl.receive_data(frame(AA), 0.0)
    with pytest.raises(UsageError, match="packet"):
        ctl.send_answer([], After.DONE, 0.0)
    assert ctl.state is State.HANDLING


def test_a_bad_answer_packet_is_refused_before_any_is_sent() -> None:
    ctl = ControllerLink()
    ctl.receive_data(frame(AB), 0.0)
    with pytest.raises(PacketTooLongError):
        ctl.send_answer([ALARM_1, b"0" + b"A" * 300, END], After.DONE, 0.0)
    assert ctl.data_to_send() == b""
    assert ctl.state is State.HANDLING
    with pytest.raises(PacketTooLongError):
        ctl.send_answer([b"0\x03"], After.DONE, 0.0)
    assert ctl.data_to_send() == b""
    ctl.send_answer([ALARM_1, END], After.DONE, 0.0)
    assert ctl.data_to_send() == frame(ALARM_1)


def test_a_bad_request_or_line_is_refused_before_anything_is_sent() -> None:
    host = HostLink()
    with pytest.raises(PacketTooLongError):
        host.send_request(b"\xffFB" + b"x" * 300, Shape.UPLOAD, 0.0)
    assert host.data_to_send() == b""
    assert host.idle and host.next_deadline() is None
    host.send_request(FB, Shape.UPLOAD, 0.0)
    host.receive_data(frame(FB_OK), 0.0)
    host.data_to_send()
    with pytest.raises(PacketTooLongError):
        host.send_upload_line(b"\x02", 0.0)
    assert host.data_to_send() == b""
    assert host.state is State.UPLOAD_READY


def test_frame_decoder_misuse_is_not_swallowed() -> None:
    from robostar.errors import FrameError

    with pytest.raises(FrameError):
        HostLink().receive_data("02 30 03 30", 0.0)  # type: ignore[arg-type]


# ===============================================================================================
# The application's turn: line input that arrives meanwhile waits for its next call. An RST or
# a packet among it shows that the peer moved on: the call then sends nothing.
# ===============================================================================================
def test_an_rst_right_behind_a_request_cancels_the_answer() -> None:
    # Regression: this read crashed the simulator. The RST reset the controller before its
    # application had seen the request, so its answer raised LinkRuleError. Now the RST waits
    # for the answer, which it cancels: the host has given up on AA, and an answer would only
    # meet its next request.
    ctl = ControllerLink()
    read = bytes.fromhex("02 FF 41 41 03 FF 12")
    assert read == frame(AA) + RST_B
    assert ctl.receive_data(read, 0.0) == [
        RequestReceived(AA),
        PeerMovedOn(State.HANDLING),  # told at once: the turn began with it held
    ]
    assert ctl.data_to_send() == b""
    assert ctl.state is State.HANDLING and ctl.next_deadline() is None
    assert ctl.send_answer([AA_ANSWER], After.DONE, 0.1) == [
        ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED)
    ]
    assert ctl.data_to_send() == b""
    assert ctl.idle and ctl.next_deadline() is None
    # Nothing is left held: the next request is taken at once.
    assert ctl.receive_data(frame(AB), 0.2) == [RequestReceived(AB)]


def test_a_second_request_right_behind_a_request_supersedes_it_unanswered() -> None:
    ctl = ControllerLink()
    assert ctl.receive_data(frame(AA) + frame(AB), 0.0) == [
        RequestReceived(AA),
        PeerMovedOn(State.HANDLING),  # told at once: the turn began with it held
    ]
    assert ctl.data_to_send() == b""
    assert ctl.state is State.HANDLING and ctl.next_deadline() is None
    assert ctl.send_answer([AA_ANSWER], After.DONE, 0.1) == [
        ExchangeFailed(FailReason.SUPERSEDED, State.HANDLING, "a new request came first"),
        RequestReceived(AB),
    ]
    assert ctl.data_to_send() == b""
    assert ctl.state is State.HANDLING and ctl.next_deadline() is None
    assert ctl.send_answer([ALARM_1, END], After.DONE, 0.2) == []
    assert ctl.data_to_send() == frame(ALARM_1)
    assert ctl.state is State.WAIT_ACK
    assert ctl.next_deadline() == pytest.approx(2.2)


def test_a_non_request_packet_behind_a_request_breaks_a_rule_in_place_of_the_answer() -> None:
    ctl = ControllerLink()
    assert ctl.receive_data(frame(AA) + frame(OK), 0.0) == [
        RequestReceived(AA),
        PeerMovedOn(State.HANDLING),  # told at once: the turn began with it held
    ]
    assert ctl.data_to_send() == b""
    assert plain(ctl.send_answer([AA_ANSWER], After.DONE, 0.1)) == [
        (
            ExchangeFailed(
                FailReason.RULE,
                State.HANDLING,
                "controller link in state HANDLING cannot take packet: during our turn",
            ),
            ("controller", "HANDLING", "packet"),
        )
    ]
    assert ctl.data_to_send() == RST_B
    assert ctl.idle and ctl.next_deadline() is None


def test_held_input_is_taken_in_order_until_the_applications_next_turn() -> None:
    ctl = ControllerLink()
    read = frame(AA) + frame(AB) + RST_B
    assert ctl.receive_data(read, 0.0) == [
        RequestReceived(AA),
        PeerMovedOn(State.HANDLING),  # told at once: the turn began with it held
    ]
    # AB starts the application's next turn: the RST behind it waits again, and cancels AB's
    # answer in its turn.
    assert ctl.send_answer([AA_ANSWER], After.DONE, 0.1) == [
        ExchangeFailed(FailReason.SUPERSEDED, State.HANDLING, "a new request came first"),
        RequestReceived(AB),
        PeerMovedOn(State.HANDLING),  # AB's turn begins with the RST held: told at once
    ]
    assert ctl.data_to_send() == b""
    assert ctl.state is State.HANDLING and ctl.next_deadline() is None
    assert ctl.send_answer([ALARM_1, END], After.DONE, 0.2) == [
        ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED)
    ]
    assert ctl.data_to_send() == b""
    assert ctl.idle and ctl.next_deadline() is None


def test_input_held_across_reads_keeps_its_order() -> None:
    ctl = ControllerLink()
    assert ctl.receive_data(frame(AA), 0.0) == [RequestReceived(AA)]
    assert ctl.receive_data(RST_B, 0.05) == [PeerMovedOn(State.HANDLING)]  # told once
    assert ctl.receive_data(frame(AB), 0.08) == []
    assert ctl.data_to_send() == b""
    assert ctl.state is State.HANDLING
    assert ctl.send_answer([AA_ANSWER], After.DONE, 0.1) == [
        ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED),
        RequestReceived(AB),
    ]
    assert ctl.data_to_send() == b""
    assert ctl.state is State.HANDLING and ctl.next_deadline() is None


def test_a_controller_tells_at_once_once_a_turn_that_its_host_moved_on() -> None:
    # The application may drop work nobody waits for as soon as the host gives up, not only at
    # its answer: noise does not show it, an RST or a packet does, and a new turn is told anew.
    ctl = ControllerLink()
    assert ctl.receive_data(frame(AA), 0.0) == [RequestReceived(AA)]
    assert ctl.receive_data(ACK_B + NAK_B + BAD_LRC, 0.1) == []
    assert ctl.receive_data(RST_B, 0.2) == [PeerMovedOn(State.HANDLING)]
    assert ctl.receive_data(frame(AB), 0.3) == []
    assert ctl.send_answer([AA_ANSWER], After.DONE, 0.4) == [
        ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED),
        RequestReceived(AB),
    ]
    assert ctl.receive_data(frame(AA), 0.5) == [PeerMovedOn(State.HANDLING)]
    # The closing packet of an upload is the application's turn too.
    ctl = ControllerLink()
    ctl.receive_data(frame(FB), 0.0)
    ctl.send_answer([FB_OK], After.UPLOAD, 0.0)
    assert ctl.receive_data(frame(END), 0.1) == [UploadPacketReceived(b"", end=True)]
    assert ctl.receive_data(RST_B, 0.2) == [PeerMovedOn(State.UPLOAD_HANDLING)]
    assert ctl.accept_upload(0.3) == [
        ExchangeFailed(FailReason.RESET, State.UPLOAD_HANDLING, CANCELLED)
    ]
    assert ctl.data_to_send() == frame(FB_OK)


def test_held_noise_up_to_the_peers_move_is_dropped_and_the_rest_taken_in_order() -> None:
    # The NAK and the corrupt frame before the RST belong to the exchange the host reset: no
    # resend, no NAK. The corrupt frame after it is new line noise: NAKed in LISTEN.
    ctl = ControllerLink()
    read = frame(AA) + NAK_B + BAD_LRC + RST_B + BAD_LRC + frame(AB)
    assert ctl.receive_data(read, 0.0) == [
        RequestReceived(AA),
        PeerMovedOn(State.HANDLING),  # told at once: the turn began with it held
    ]
    assert ctl.send_answer([AA_ANSWER], After.DONE, 0.1) == [
        ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED),
        RequestReceived(AB),
    ]
    assert ctl.data_to_send() == NAK_B
    assert ctl.state is State.HANDLING and ctl.next_deadline() is None
    # Before a new request, the held noise is dropped; the request is kept.
    ctl = ControllerLink()
    assert ctl.receive_data(frame(AA) + NAK_B + BAD_LRC + frame(AB), 0.0) == [
        RequestReceived(AA),
        PeerMovedOn(State.HANDLING),
    ]
    assert ctl.send_answer([AA_ANSWER], After.DONE, 0.1) == [
        ExchangeFailed(FailReason.SUPERSEDED, State.HANDLING, "a new request came first"),
        RequestReceived(AB),
    ]
    assert ctl.data_to_send() == b""
    assert ctl.state is State.HANDLING and ctl.next_deadline() is None


def test_held_noise_alone_is_taken_after_the_answer() -> None:
    ctl = ControllerLink()
    assert ctl.receive_data(frame(AA) + BAD_LRC + NAK_B, 0.0) == [RequestReceived(AA)]
    assert ctl.send_answer([AA_ANSWER], After.DONE, 0.1) == []
    assert ctl.data_to_send() == frame(AA_ANSWER) + NAK_B + frame(AA_ANSWER)
    assert ctl.state is State.WAIT_ACK
    assert ctl.next_deadline() == pytest.approx(2.1)


def test_abort_is_the_applications_call_too() -> None:
    # An RST held behind the request: at the application's abort, as at its answer, the host
    # has moved on (RESET) and nothing is sent; the RST is not read as stray input after it.
    ctl = ControllerLink()
    assert ctl.receive_data(frame(AA) + RST_B, 0.0) == [
        RequestReceived(AA),
        PeerMovedOn(State.HANDLING),  # told at once: the turn began with it held
    ]
    assert ctl.abort(0.1) == [ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED)]
    assert ctl.data_to_send() == b""
    assert ctl.idle and ctl.next_deadline() is None


def test_an_end_packet_read_with_the_upload_line_breaks_a_rule_in_place_of_the_reply() -> None:
    # The host must wait for the line's reply before its END packet: both in one read is a rule
    # it broke. The reply is not sent; RST is.
    ctl = ControllerLink()
    ctl.receive_data(frame(FB), 0.0)
    ctl.send_answer([FB_OK], After.UPLOAD, 0.0)
    ctl.data_to_send()
    assert ctl.receive_data(frame(OK + LINE_1) + frame(END), 0.1) == [
        UploadPacketReceived(LINE_1, end=False),
        PeerMovedOn(State.UPLOAD_HANDLING),  # the END held behind the line: told at once
    ]
    assert ctl.data_to_send() == b""
    assert ctl.state is State.UPLOAD_HANDLING and ctl.next_deadline() is None
    assert plain(ctl.send_answer([FB_OK], After.UPLOAD, 0.2)) == [
        (
            ExchangeFailed(
                FailReason.RULE,
                State.UPLOAD_HANDLING,
                "controller link in state UPLOAD_HANDLING cannot take packet: during our turn",
            ),
            ("controller", "UPLOAD_HANDLING", "packet"),
        )
    ]
    assert ctl.data_to_send() == RST_B
    assert ctl.idle and ctl.next_deadline() is None


def test_a_stale_end_packet_behind_the_upload_reply_fails_the_upload_before_the_line() -> None:
    host = HostLink()
    host.send_request(FB, Shape.UPLOAD, 0.0)
    host.data_to_send()
    assert host.receive_data(frame(FB_OK) + frame(END), 0.1) == [UploadReady(FB_OK)]
    assert host.data_to_send() == b""
    assert host.state is State.UPLOAD_READY and host.next_deadline() is None
    assert plain(host.send_upload_line(LINE_1, 0.2)) == [
        (
            ExchangeFailed(
                FailReason.RULE,
                State.UPLOAD_READY,
                "host link in state UPLOAD_READY cannot take packet: during our turn",
            ),
            ("host", "UPLOAD_READY", "packet"),
        )
    ]
    assert host.data_to_send() == RST_B
    assert host.state is State.RESYNC
    assert host.next_deadline() == pytest.approx(0.2 + GAP)


@pytest.mark.parametrize(
    ("held", "events", "written", "after"),
    [
        (
            RST_B,
            [ExchangeFailed(FailReason.RESET, State.UPLOAD_HANDLING, CANCELLED)],
            b"",
            State.LISTEN,
        ),
        (
            frame(AA),
            [
                ExchangeFailed(
                    FailReason.SUPERSEDED, State.UPLOAD_HANDLING, "a new request came first"
                ),
                RequestReceived(AA),
            ],
            b"",
            State.HANDLING,
        ),
        (NAK_B, [ExchangeComplete(), Ignored("stray input", State.LISTEN)], ACK_B, State.LISTEN),
    ],
    ids=["RST", "request", "NAK"],
)
def test_input_held_behind_the_end_packet_meets_accept_upload(
    held: bytes, events: list[LinkEvent], written: bytes, after: State
) -> None:
    ctl = ControllerLink()
    ctl.receive_data(frame(FB), 0.0)
    ctl.send_answer([FB_OK], After.UPLOAD, 0.0)
    ctl.data_to_send()
    told = [] if held == NAK_B else [PeerMovedOn(State.UPLOAD_HANDLING)]  # noise is not told
    assert ctl.receive_data(frame(END) + held, 0.1) == [UploadPacketReceived(b"", end=True), *told]
    assert ctl.accept_upload(0.2) == events
    assert ctl.data_to_send() == written
    assert ctl.state is after
    assert ctl.next_deadline() is None


@pytest.mark.parametrize(
    ("held", "events", "written", "after", "deadline"),
    [
        (
            RST_B,
            [ExchangeFailed(FailReason.RESET, State.UPLOAD_READY, CANCELLED)],
            b"",
            State.IDLE,
            None,
        ),
        (
            frame(FB_OK),
            [
                (
                    ExchangeFailed(
                        FailReason.RULE,
                        State.UPLOAD_READY,
                        "host link in state UPLOAD_READY cannot take packet: during our turn",
                    ),
                    ("host", "UPLOAD_READY", "packet"),
                )
            ],
            RST_B,
            State.RESYNC,
            0.2 + 0.25,  # the default resync gap (GAP, below)
        ),
        (NAK_B, [], frame(END) * 2, State.UPLOAD_WAIT_ACK, 0.2 + 2.0),
    ],
    ids=["RST", "packet", "NAK"],
)
def test_input_held_behind_the_upload_reply_meets_the_end_packet(
    held: bytes, events: list[object], written: bytes, after: State, deadline: float | None
) -> None:
    host = HostLink()
    host.send_request(FB, Shape.UPLOAD, 0.0)
    host.data_to_send()
    assert host.receive_data(frame(FB_OK) + held, 0.1) == [UploadReady(FB_OK)]
    assert plain(host.send_upload_end(0.2)) == events
    assert host.data_to_send() == written
    assert host.state is after
    assert host.next_deadline() == (None if deadline is None else pytest.approx(deadline))


# ===============================================================================================
# Hazards a faulty line used to cause: each test states what the link guarantees. The
# application sends its next request at once after a failed exchange; the link takes it.
# ===============================================================================================
def test_a_resend_crossing_the_hosts_rst_is_not_the_next_answer() -> None:
    # The answer to AC is lost. Host and controller time out together (equal 2 s timeouts): the
    # host sends RST and at once its next request, BA; the controller resends the AC answer.
    # That copy reaches the host while it waits for BA's answer.
    host, ctl = HostLink(), ControllerLink()
    host.send_request(b"\xffAC01", Shape.SINGLE, 0.0)
    ctl.receive_data(host.data_to_send(), 0.0)
    ctl.send_answer([b"0 stale position"], After.DONE, 0.0)
    ctl.data_to_send()  # lost
    host.handle_timeout(2.0)
    ctl.handle_timeout(2.0)
    stale = ctl.data_to_send()
    assert stale == frame(b"0 stale position")
    events = host.send_request(b"\xffBA0", Shape.SINGLE, 2.0)
    events += host.receive_data(stale, 2.01)
    # The stale AC answer must not complete BA: BA has not even reached the controller.
    assert b"0 stale position" not in answers(events)


def test_a_nak_for_an_old_frame_does_not_resend_a_taken_request() -> None:
    # The LRC byte of the host's AC request is lost, so the controller's decoder takes the
    # host's RST (sent on timeout) as that LRC, finds it wrong and answers NAK. The NAK reaches
    # the host after it has sent its next request, BA, which the controller took whole.
    host, ctl = HostLink(), ControllerLink()
    host.send_request(b"\xffAC01", Shape.SINGLE, 0.0)
    ctl.receive_data(host.data_to_send()[:-1], 0.0)  # the LRC byte is lost
    host.handle_timeout(2.0)
    host.send_request(b"\xffBA0", Shape.SINGLE, 2.0)
    taken = ctl.receive_data(host.data_to_send(), 2.01)
    nak = ctl.data_to_send()
    assert nak == NAK_B
    if RequestReceived(b"\xffBA0") in taken:
        ctl.send_answer([OK], After.DONE, 2.01)
    host.receive_data(nak + ctl.data_to_send(), 2.02)
    taken += ctl.receive_data(host.data_to_send(), 2.03)
    # BA (a homing move) must reach the controller's application once.
    assert taken.count(RequestReceived(b"\xffBA0")) <= 1


def test_a_lost_ack_mid_multi_is_recovered_with_equal_timeouts() -> None:
    # Both ends use the default 2 s. The host ACKs ALARM_1 10 ms after it was sent; the ACK is
    # lost. The controller's resend, due 2 s after it first sent ALARM_1 and polled 5 ms late,
    # reaches the host 10 ms later still: after the host's own 2 s from its ACK ran out.
    host, ctl = HostLink(), ControllerLink()
    host.send_request(AB, Shape.MULTI, 0.0)
    ctl.receive_data(host.data_to_send(), 0.0)
    ctl.send_answer([ALARM_1, END], After.DONE, 0.0)
    host.receive_data(ctl.data_to_send(), 0.01)
    host.data_to_send()  # the ACK is lost
    ctl.handle_timeout(2.005)
    resend = ctl.data_to_send()
    events = host.handle_timeout(2.01)
    events += host.receive_data(resend, 2.015)
    ctl.receive_data(host.data_to_send(), 2.025)
    events += host.receive_data(ctl.data_to_send(), 2.03)
    assert not failures(events)
    assert answers(events) == [END]


# ===============================================================================================
# RESYNC: the host's quiet gap after its own RST
# ===============================================================================================
GAP = 0.25
"""HostLink's default resync_gap."""
AC = b"\xffAC01"
BA = b"\xffBA0"
STALE = b"0 stale position"
RST_HANDLERS = {
    "_h_timeout": FailReason.TIMEOUT,
    "_abort": FailReason.ABORTED,
    "_resend": FailReason.NAK_LIMIT,
    "_nak_corrupt": FailReason.NAK_LIMIT,
}
"""The host's table handlers that can end an exchange with its own RST, and why they do."""


_ONCE_ONLY_NAKS = {(State.UPLOAD_WAIT_REPLY, Input.NAK), (State.UPLOAD_WAIT_ACK, Input.NAK)}
"""An upload changes state: after one resend a NAK brings no other copy (it may be a doubled
one), so NAKs never reach the NAK limit there; the exchange ends at its timeout (tested in
test_an_upload_line_is_resent_once_for_a_nak_storm)."""


def _host_rst_entries() -> list[tuple[State, Input]]:
    return sorted(
        (
            (state, what)
            for (role, state, what), name in TRANSITIONS.items()
            if role is Role.HOST and name in RST_HANDLERS and (state, what) not in _ONCE_ONLY_NAKS
        ),
        key=lambda k: (k[0].value, k[1].value),
    )


LAST_SENT = {
    State.WAIT_ANSWER: frame(b"\xffXX"),
    State.WAIT_FENCE: frame(AA),
    State.UPLOAD_WAIT_REPLY: frame(FB),
    State.UPLOAD_WAIT_ACK: frame(END),
}
"""The frame a host built by SETUPS sent last in each state that resends on NAK."""


def _drive_to_rst(link: Link, state: State, what: Input) -> tuple[list[LinkEvent], float]:
    """Give ``link`` the input of one entry until it sends RST; the events and the time then."""
    now = T0 + 0.5
    if what is Input.TIMEOUT:
        deadline = link.next_deadline()
        assert deadline is not None
        return link.handle_timeout(deadline), deadline
    if what is Input.ABORT:
        return link.abort(now), now
    # Three NAKs are resends, three corrupt packets are NAKed; the fourth is the RST.
    one, reply = (NAK_B, LAST_SENT[state]) if what is Input.NAK else (BAD_LRC, NAK_B)
    for _ in range(MAX_NAKS):
        assert link.receive_data(one, now) == []
        assert link.data_to_send() == reply
    return link.receive_data(one, now), now


def test_the_host_rst_entries_are_the_ones_expected() -> None:
    waiting = {
        State.WAIT_ANSWER,
        State.WAIT_MORE,
        State.WAIT_SECOND,
        State.UPLOAD_WAIT_REPLY,
        State.UPLOAD_WAIT_ACK,
        State.WAIT_FENCE,
    }
    # a read's request (a fence is one); an upload's NAKs end by timeout
    sending = {State.WAIT_ANSWER, State.WAIT_FENCE}
    assert set(_host_rst_entries()) == (
        {(state, Input.TIMEOUT) for state in waiting}
        | {(state, Input.CORRUPT) for state in waiting}
        | {(state, Input.ABORT) for state in waiting | {State.UPLOAD_READY}}
        | {(state, Input.NAK) for state in sending}
    )


@pytest.mark.parametrize("key", _host_rst_entries(), ids=str)
def test_every_rst_the_host_sends_starts_the_gap(key: tuple[State, Input]) -> None:
    state, what = key
    link = SETUPS[(Role.HOST, state)]()
    events, now = _drive_to_rst(link, state, what)
    # ExchangeFailed comes at once, not at the end of the gap.
    [failed] = failures(events)
    assert (failed.reason, failed.state) == (RST_HANDLERS[TRANSITIONS[(Role.HOST, *key)]], state)
    assert events == [failed]
    assert link.data_to_send() == RST_B
    assert link.state is State.RESYNC
    # After its own abort too the host waits the whole gap (only a stop may go out after
    # abort_gap: test_link_abort_gap.py).
    assert isinstance(link, HostLink)
    gap = GAP
    assert link.next_deadline() == pytest.approx(now + gap)
    assert not link.idle and not link.busy
    assert link.decoder.pending == 0
    assert link.handle_timeout(now + gap) == []
    assert link.data_to_send() == b""
    assert link.idle and link.next_deadline() is None


@pytest.mark.parametrize("key", _host_rst_entries(), ids=str)
def test_without_a_gap_every_rst_the_host_sends_returns_it_to_idle(
    key: tuple[State, Input],
) -> None:
    state, what = key
    link = SETUPS[(Role.HOST, state)]()
    assert isinstance(link, HostLink)
    link.resync_gap = link.abort_gap = 0
    events, now = _drive_to_rst(link, state, what)
    assert [(f.reason, f.state) for f in failures(events)] == [
        (RST_HANDLERS[TRANSITIONS[(Role.HOST, *key)]], state)
    ]
    assert link.data_to_send() == RST_B
    assert link.idle and link.next_deadline() is None
    assert link.send_request(AA, Shape.SINGLE, now) == []
    assert link.data_to_send() == frame(AA)
    # a host with a fence sends it first (here AA itself), the request behind it
    assert link.state is (State.WAIT_FENCE if link.fences else State.WAIT_ANSWER)
    assert link.next_deadline() == pytest.approx(now + 2.0)


def test_a_rule_broken_by_the_controller_starts_the_gap_too() -> None:
    host = HostLink()
    host.send_request(FB, Shape.UPLOAD, 0.0)
    host.receive_data(frame(FB_OK), 0.0)
    host.send_upload_end(0.0)
    host.data_to_send()
    events = host.receive_data(frame(FB_OK), 0.5)  # an OK reply in place of the lone ACK
    assert [(f.reason, f.state) for f in failures(events)] == [
        (FailReason.RULE, State.UPLOAD_WAIT_ACK)
    ]
    assert host.data_to_send() == RST_B
    assert host.state is State.RESYNC and host.next_deadline() == pytest.approx(0.75)


@pytest.mark.parametrize(
    "state",
    [
        state
        for (role, state, what), name in TRANSITIONS.items()
        if role is Role.HOST and name == "_reset_by_peer"
    ],
)
def test_an_rst_from_the_controller_needs_no_gap(state: State) -> None:
    # The controller ended the exchange: nothing of it is left in flight towards the host.
    link = SETUPS[(Role.HOST, state)]()
    events = link.receive_data(RST_B, T0 + 0.5)
    assert [(f.reason, f.state) for f in failures(events)] == [(FailReason.RESET, state)]
    assert link.data_to_send() == b""
    assert link.idle and link.next_deadline() is None
    assert isinstance(link, HostLink)
    link.send_request(AA, Shape.SINGLE, T0 + 0.5)
    assert link.data_to_send() == frame(AA)


def _resynced(**options: float) -> HostLink:
    """A host whose AA request (sent at 0.0) timed out at 2.0: RST sent, quiet until 2.25."""
    host = HostLink(**options)
    host.send_request(AA, Shape.SINGLE, 0.0)
    host.data_to_send()
    assert [f.reason for f in failures(host.handle_timeout(2.0))] == [FailReason.TIMEOUT]
    assert host.data_to_send() == RST_B
    assert host.state is State.RESYNC and host.next_deadline() == 2.0 + host.resync_gap
    return host


@pytest.mark.parametrize("data", [AA_ANSWER, ALARM_1, END, b"2", b"9", FB_OK])
def test_resync_answers_any_intact_packet_with_rst_and_restarts_the_gap(data: bytes) -> None:
    host = _resynced()
    assert host.receive_data(frame(data), 2.1) == [
        Ignored("stale packet in the resync gap (RST)", State.RESYNC)
    ]
    assert host.data_to_send() == RST_B
    assert host.state is State.RESYNC
    assert host.next_deadline() == pytest.approx(2.1 + GAP)
    assert host.handle_timeout(2.3499) == []
    assert host.state is State.RESYNC
    assert host.handle_timeout(2.35) == []
    assert host.data_to_send() == b""
    assert host.idle and host.next_deadline() is None


@pytest.mark.parametrize("data", [ACK_B, NAK_B, RST_B], ids=["ACK", "NAK", "RST"])
def test_resync_ignores_control_bytes_and_keeps_the_deadline(data: bytes) -> None:
    host = _resynced()
    assert host.receive_data(data, 2.1) == [Ignored("stray input", State.RESYNC)]
    assert host.data_to_send() == b""
    assert host.state is State.RESYNC and host.next_deadline() == 2.0 + GAP


def test_resync_restarts_the_gap_on_a_corrupt_frame_and_sends_nothing() -> None:
    host = _resynced()
    assert host.receive_data(BAD_LRC, 2.1) == [
        Ignored("corrupt frame in the resync gap", State.RESYNC)
    ]
    assert host.data_to_send() == b""
    assert host.state is State.RESYNC
    assert host.next_deadline() == pytest.approx(2.1 + GAP)


def test_resync_neither_naks_nor_rsts_a_run_of_corrupt_packets() -> None:
    host = _resynced()
    events = host.receive_data(BAD_LRC * (MAX_NAKS + 2), 2.1)
    assert events == [Ignored("corrupt frame in the resync gap", State.RESYNC)] * (MAX_NAKS + 2)
    assert host.data_to_send() == b""
    assert host.state is State.RESYNC
    assert host.next_deadline() == pytest.approx(2.1 + GAP)


def test_a_frame_cut_short_in_the_gap_restarts_it_only_with_the_frame_that_cut_it() -> None:
    host = _resynced()
    assert host.receive_data(bytes.fromhex("02 30 B5"), 2.1) == []
    assert host.next_deadline() == 2.0 + GAP
    assert host.receive_data(frame(STALE), 2.2) == [
        Ignored("frame cut short by a new STX", State.RESYNC),
        Ignored("stale packet in the resync gap (RST)", State.RESYNC),
    ]
    assert host.data_to_send() == RST_B
    assert host.next_deadline() == pytest.approx(2.2 + GAP)


def test_a_deferred_request_waits_for_a_whole_quiet_gap() -> None:
    host = _resynced()
    assert host.send_request(BA, Shape.SINGLE, 2.05) == []
    host.receive_data(frame(STALE), 2.1)
    host.receive_data(BAD_LRC, 2.3)
    assert host.data_to_send() == RST_B
    assert host.next_deadline() == pytest.approx(2.3 + GAP)
    # The first deadline has moved on: nothing goes out at 2.25 or 2.35.
    assert host.handle_timeout(2.35) == []
    assert host.handle_timeout(2.5499) == []
    assert host.data_to_send() == b""
    assert host.state is State.RESYNC
    assert host.handle_timeout(2.55) == []
    assert host.data_to_send() == frame(BA)
    assert host.state is State.WAIT_ANSWER
    assert host.next_deadline() == pytest.approx(2.55 + 2.0)


def test_the_gap_with_nothing_deferred_ends_in_idle_and_nothing_before_it() -> None:
    host = _resynced()
    assert host.handle_timeout(2.2499) == []
    assert (host.state, host.next_deadline()) == (State.RESYNC, 2.0 + GAP)
    assert host.handle_timeout(2.25) == []
    assert host.data_to_send() == b""
    assert host.idle and host.next_deadline() is None
    # After the gap a request goes out at once.
    assert host.send_request(AB, Shape.MULTI, 2.3) == []
    assert host.data_to_send() == frame(AB)
    assert host.state is State.WAIT_ANSWER and host.next_deadline() == pytest.approx(4.3)


@pytest.mark.parametrize(
    ("shape", "data", "waiting"),
    [
        (Shape.SINGLE, AA, State.WAIT_ANSWER),
        (Shape.MULTI, AB, State.WAIT_ANSWER),
        (Shape.TWO_PHASE, DB, State.WAIT_ANSWER),
        (Shape.UPLOAD, FB, State.UPLOAD_WAIT_REPLY),
    ],
)
@pytest.mark.parametrize("polled", [2.25, 2.4])
def test_a_request_during_the_gap_goes_out_exactly_at_its_end(
    shape: Shape, data: bytes, waiting: State, polled: float
) -> None:
    host = _resynced()
    assert host.send_request(data, shape, 2.1) == []
    assert host.data_to_send() == b""
    assert host.state is State.RESYNC and host.next_deadline() == 2.0 + GAP
    assert not host.busy and not host.idle
    assert host.handle_timeout(2.2499) == []
    assert host.data_to_send() == b""
    assert host.state is State.RESYNC
    # The driver polls at the deadline or later; the reply timer runs from the sending.
    assert host.handle_timeout(polled) == []
    assert host.data_to_send() == frame(data)
    assert host.state is waiting and host.shape is shape
    assert host.next_deadline() == pytest.approx(polled + 2.0)
    assert host.busy
    assert host.handle_timeout(polled + 1.0) == []
    assert host.data_to_send() == b""


def test_a_deferred_request_runs_a_whole_exchange() -> None:
    # AC's answer is lost; the controller (5 s) has not resent it when the host gives up.
    pair = Pair(ctl=ControllerLink(timeout=5.0))
    pair.request(AC)
    pair.ctl.send_answer([STALE], After.DONE, 0.0)
    assert pair.ctl.data_to_send() == frame(STALE)  # lost
    pair.at(2.0)
    host, ctl = pair.take()
    assert [(f.reason, f.state) for f in failures(host)] == [
        (FailReason.TIMEOUT, State.WAIT_ANSWER)
    ]
    assert [(f.reason, f.state) for f in failures(ctl)] == [(FailReason.RESET, State.WAIT_ACK)]
    pair.request(AB, Shape.MULTI)
    assert pair.take() == ([], [])
    assert pair.to_ctl == [frame(AC), RST_B]
    pair.at(2.25)
    pair.answer([ALARM_1, ALARM_2, END])
    host, ctl = pair.take()
    assert host == [
        AnswerReceived(ALARM_1, 0x30, final=False),
        AnswerReceived(ALARM_2, 0x30, final=False),
        AnswerReceived(END, 0x34, final=True),
        ExchangeComplete(),
    ]
    assert ctl == [RequestReceived(AB), ExchangeComplete()]
    assert pair.to_ctl == [frame(AC), RST_B, frame(AB), ACK_B, ACK_B, ACK_B]
    assert pair.host.idle and pair.ctl.idle


def test_a_stale_answer_in_the_gap_is_stopped_and_never_delivered() -> None:
    # AC's answer is lost; the controller's resend crosses the host's RST on the line and
    # arrives while the host's next request, BA, waits for the end of the gap. The host answers
    # it with RST and waits a whole gap from then.
    host, ctl = HostLink(), ControllerLink()
    host.send_request(AC, Shape.SINGLE, 0.0)
    assert ctl.receive_data(host.data_to_send(), 0.0) == [RequestReceived(AC)]
    ctl.send_answer([STALE], After.DONE, 0.05)
    ctl.data_to_send()  # lost
    events = host.handle_timeout(2.0)
    rst = host.data_to_send()
    assert rst == RST_B
    events += host.send_request(BA, Shape.SINGLE, 2.0)
    assert host.data_to_send() == b""
    assert ctl.handle_timeout(2.05) == []
    stale = ctl.data_to_send()
    assert stale == frame(STALE)
    events += host.receive_data(stale, 2.06)
    second_rst = host.data_to_send()
    assert second_rst == RST_B
    assert host.next_deadline() == pytest.approx(2.06 + GAP)
    assert ctl.receive_data(rst + second_rst, 2.07) == [
        ExchangeFailed(FailReason.RESET, State.WAIT_ACK, "RST received"),
        Ignored("stray input", State.LISTEN),
    ]
    events += host.handle_timeout(2.25)
    assert host.data_to_send() == b""
    events += host.handle_timeout(2.31)
    request = host.data_to_send()
    assert request == frame(BA)
    assert ctl.receive_data(request, 2.32) == [RequestReceived(BA)]
    ctl.send_answer([OK], After.DONE, 2.33)
    events += host.receive_data(ctl.data_to_send(), 2.34)
    assert events == [
        ExchangeFailed(FailReason.TIMEOUT, State.WAIT_ANSWER, "no answer within 2 s"),
        Ignored("stale packet in the resync gap (RST)", State.RESYNC),
        AnswerReceived(OK, 0x30, final=True),
        ExchangeComplete(),
    ]
    assert ctl.receive_data(host.data_to_send(), 2.35) == [ExchangeComplete()]


def _late_nak_scenario(
    host: HostLink,
) -> tuple[list[LinkEvent], list[tuple[float, bytes]], list[LinkEvent]]:
    """AC's LRC byte is lost, so the controller takes the host's RST (sent on timeout) as that
    LRC and NAKs; the host asks for BA at once. The controller answers each request as soon as
    it takes it. Returns the host's events, its writes (time, bytes) and the controller's
    events."""
    ctl = ControllerLink()
    host.send_request(AC, Shape.SINGLE, 0.0)
    assert ctl.receive_data(host.data_to_send()[:-1], 0.0) == []
    events = host.handle_timeout(2.0)
    events += host.send_request(BA, Shape.SINGLE, 2.0)
    writes: list[tuple[float, bytes]] = []
    ctl_events: list[LinkEvent] = []
    for now in (2.0, 2.05, 2.1, 2.25, 2.3, 2.35):
        events += host.handle_timeout(now)
        write = host.data_to_send()
        if write:
            writes.append((now, write))
        ctl_events += ctl.receive_data(write, now)
        if ctl.state is State.HANDLING:
            ctl_events += ctl.send_answer([OK], After.DONE, now)
        events += host.receive_data(ctl.data_to_send(), now)
    assert host.idle and ctl.idle
    return events, writes, ctl_events


def test_a_late_nak_in_the_gap_causes_no_resend() -> None:
    events, writes, ctl_events = _late_nak_scenario(HostLink())
    assert writes == [(2.0, RST_B), (2.25, frame(BA)), (2.3, ACK_B)]
    assert ctl_events == [RequestReceived(BA), ExchangeComplete()]
    assert events == [
        ExchangeFailed(FailReason.TIMEOUT, State.WAIT_ANSWER, "no answer within 2 s"),
        Ignored("stray input", State.RESYNC),  # the NAK
        AnswerReceived(OK, 0x30, final=True),
        ExchangeComplete(),
    ]


def test_without_a_gap_the_late_nak_resends_the_next_request() -> None:
    # resync_gap=0 is the old link: BA goes out with the RST and the NAK meant for AC resends
    # it, so BA reaches the controller's application twice. This is what the gap prevents.
    events, writes, ctl_events = _late_nak_scenario(HostLink(resync_gap=0))
    assert writes == [(2.0, RST_B + frame(BA)), (2.05, frame(BA) + ACK_B), (2.1, ACK_B)]
    assert ctl_events == [
        RequestReceived(BA),
        ExchangeComplete(),  # the resent BA supersedes the answered one...
        RequestReceived(BA),  # ...and runs again; the first answer's ACK, read with it, waited
        ExchangeComplete(),  # for the second answer and is taken as its ACK
        Ignored("stray input", State.LISTEN),  # the host's ACK of the second answer
    ]
    assert events == [
        ExchangeFailed(FailReason.TIMEOUT, State.WAIT_ANSWER, "no answer within 2 s"),
        AnswerReceived(OK, 0x30, final=True),
        ExchangeComplete(),
        Ignored("resent answer outside an exchange (ACKed again)", State.IDLE),
    ]


def test_without_a_gap_a_stale_answer_lands_on_the_next_request() -> None:
    # resync_gap=0 is the old link: the controller's resend of AC's answer, crossing the RST,
    # is taken as the answer to BA. This is what the gap prevents.
    host, ctl = HostLink(resync_gap=0), ControllerLink()
    host.send_request(AC, Shape.SINGLE, 0.0)
    ctl.receive_data(host.data_to_send(), 0.0)
    ctl.send_answer([STALE], After.DONE, 0.05)
    ctl.data_to_send()  # lost
    host.handle_timeout(2.0)
    assert host.idle and host.next_deadline() is None
    assert host.send_request(BA, Shape.SINGLE, 2.0) == []
    assert host.data_to_send() == RST_B + frame(BA)
    ctl.handle_timeout(2.05)
    assert host.receive_data(ctl.data_to_send(), 2.06) == [
        AnswerReceived(STALE, 0x30, final=True),
        ExchangeComplete(),
    ]


def test_abort_in_the_gap_drops_the_deferred_request() -> None:
    host = _resynced()
    host.send_request(AB, Shape.MULTI, 2.1)
    # The application started an exchange; it learns that it ended, and how.
    assert host.abort(2.2) == [
        ExchangeFailed(FailReason.ABORTED, State.RESYNC, "aborted before it was sent")
    ]
    assert host.data_to_send() == b""
    assert host.state is State.RESYNC and host.next_deadline() == 2.0 + GAP
    assert host.handle_timeout(2.25) == []
    assert host.data_to_send() == b""
    assert host.idle and host.next_deadline() is None
    # The next request is a fresh one and goes out at once.
    host.send_request(AA, Shape.SINGLE, 2.3)
    assert host.data_to_send() == frame(AA)
    assert host.shape is Shape.SINGLE


def test_abort_in_the_gap_with_nothing_deferred_keeps_the_gap() -> None:
    host = _resynced()
    assert host.abort(2.1) == []  # no exchange was open: nothing to report
    assert host.data_to_send() == b""  # no second RST
    assert host.state is State.RESYNC and host.next_deadline() == 2.0 + GAP


@pytest.mark.parametrize("call", ["send_upload_line", "send_upload_end"])
def test_upload_calls_in_the_gap_raise_and_change_nothing(call: str) -> None:
    host = _resynced()
    with pytest.raises(LinkRuleError) as info:
        if call == "send_upload_line":
            host.send_upload_line(LINE_1, 2.1)
        else:
            host.send_upload_end(2.1)
    assert (info.value.state, info.value.event) == ("RESYNC", call)
    assert host.data_to_send() == b""
    assert host.state is State.RESYNC and host.next_deadline() == 2.0 + GAP


def test_resync_gap_is_configurable() -> None:
    host = _resynced(resync_gap=1.5)
    assert host.next_deadline() == 3.5
    host.send_request(BA, Shape.SINGLE, 2.0)
    assert host.handle_timeout(3.4999) == []
    assert host.data_to_send() == b""
    host.handle_timeout(3.5)
    assert host.data_to_send() == frame(BA)


# ===============================================================================================
# After ACKing a packet that is not the last, the host waits timeout + resend_grace
# ===============================================================================================
@pytest.mark.parametrize("grace", [0.0, 1.0])
def test_resend_grace_is_added_after_each_non_final_packet(grace: float) -> None:
    multi = HostLink(resend_grace=grace)
    multi.send_request(AB, Shape.MULTI, 0.0)
    multi.receive_data(frame(ALARM_1), 0.3)
    assert multi.next_deadline() == pytest.approx(0.3 + 2.0 + grace)
    two_phase = HostLink(resend_grace=grace)
    two_phase.send_request(DB, Shape.TWO_PHASE, 0.0)
    two_phase.receive_data(frame(b"007"), 0.3)
    assert two_phase.next_deadline() == pytest.approx(0.3 + 7.0 + 2.0 + grace)
    # The first packet of an exchange is awaited for the plain timeout.
    single = HostLink(resend_grace=grace)
    single.send_request(AA, Shape.SINGLE, 0.3)
    assert single.next_deadline() == pytest.approx(0.3 + 2.0)


def test_a_re_ack_mid_multi_waits_timeout_and_grace_after_the_copy() -> None:
    host = HostLink()
    host.send_request(AB, Shape.MULTI, 0.0)
    host.data_to_send()
    assert answers(host.receive_data(frame(ALARM_1), 0.01)) == [ALARM_1]
    assert host.next_deadline() == pytest.approx(2.51)
    assert host.data_to_send() == ACK_B  # lost
    assert host.receive_data(frame(ALARM_1), 2.3) == [
        Ignored("resent answer (ACKed again)", State.WAIT_MORE)
    ]
    assert host.data_to_send() == ACK_B
    assert host.state is State.WAIT_MORE
    assert host.next_deadline() == pytest.approx(2.3 + 2.0 + 0.5)


def test_the_grace_hears_a_resend_polled_late_after_the_hosts_plain_timeout() -> None:
    # As the hazard test above, but the controller's resend arrives 0.49 s after the host's
    # plain 2 s from its ACK: inside the grace.
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.ctl.send_answer([ALARM_1, END], After.DONE, 0.0)
    pair.host_events += pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    assert pair.host.data_to_send() == ACK_B  # lost
    pair.at(2.49)
    host, ctl = pair.take()
    assert host == [
        AnswerReceived(ALARM_1, 0x30, final=False),
        Ignored("resent answer (ACKed again)", State.WAIT_MORE),
        AnswerReceived(END, 0x34, final=True),
        ExchangeComplete(),
    ]
    assert ctl == [RequestReceived(AB), ExchangeComplete()]


# ===============================================================================================
# busy and idle
# ===============================================================================================
@pytest.mark.parametrize("key", list(SETUPS), ids=str)
def test_busy_is_an_open_exchange_and_idle_the_idle_state(key: tuple[Role, State]) -> None:
    link = SETUPS[key]()
    _, state = key
    assert link.busy is (state not in (State.IDLE, State.LISTEN, State.RESYNC))
    assert link.idle is (state in (State.IDLE, State.LISTEN))


def test_busy_through_a_failed_exchange_and_its_gap() -> None:
    host = HostLink()
    assert not host.busy and host.idle
    host.send_request(AA, Shape.SINGLE, 0.0)
    assert host.busy and not host.idle
    host.handle_timeout(2.0)
    assert not host.busy and not host.idle  # RESYNC
    host.send_request(AB, Shape.SINGLE, 2.1)
    assert not host.busy and not host.idle  # deferred: still the gap
    host.handle_timeout(2.25)
    assert host.busy and not host.idle
    host.receive_data(frame(OK), 2.3)
    assert not host.busy and host.idle


# ===============================================================================================
# Regressions: bugs of the gap's first version, fixed in the link
# ===============================================================================================
def test_a_bad_request_in_the_gap_is_refused_at_once() -> None:
    # Every other state refuses a packet that cannot be framed in send_request itself, before
    # anything is sent; in the gap it is stored and raises later, out of handle_timeout.
    host = _resynced()
    with pytest.raises(PacketTooLongError):
        host.send_request(b"\xffFB" + b"x" * 300, Shape.UPLOAD, 2.1)
    assert host.handle_timeout(2.25) == []
    assert host.data_to_send() == b""
    assert host.idle and host.next_deadline() is None


def test_a_second_request_in_the_gap_does_not_silently_replace_the_first() -> None:
    # A request already deferred is an exchange the application is waiting on; a second
    # send_request must be refused as it is in every state with a request in flight, not drop
    # the first without an event.
    host = _resynced()
    assert host.send_request(AB, Shape.MULTI, 2.1) == []
    with pytest.raises(LinkRuleError) as info:
        host.send_request(AA, Shape.SINGLE, 2.2)
    assert (info.value.state, info.value.event) == ("RESYNC", "send_request")
    assert host.handle_timeout(2.25) == []
    assert host.data_to_send() == frame(AB)
    assert host.shape is Shape.MULTI


def test_a_re_ack_in_the_second_phase_waits_timeout_and_grace_after_the_copy() -> None:
    # DB announces 2 s: deadline 0 + 2 + 2 + 0.5 = 4.5. The ACK is lost and the copy comes at
    # 2.2; after ACKing it again the host must wait timeout + grace from then (4.7), as after any
    # non-final packet. The link compares against now + timeout only and keeps 4.5.
    host = HostLink()
    host.send_request(DB, Shape.TWO_PHASE, 0.0)
    host.receive_data(frame(DB_FIRST), 0.0)
    assert host.next_deadline() == pytest.approx(4.5)
    assert host.receive_data(frame(DB_FIRST), 2.2) == [
        Ignored("resent answer (ACKed again)", State.WAIT_SECOND)
    ]
    assert host.next_deadline() == pytest.approx(2.2 + 2.0 + 0.5)


# ===============================================================================================
# Design concerns, answered in the link: the peer may move on during the application's turn
# ===============================================================================================
@pytest.mark.parametrize("rst_lost", [False, True], ids=["RST held", "RST lost"])
def test_an_answer_to_a_request_the_host_gave_up_never_lands_on_its_next_request(
    rst_lost: bool,
) -> None:
    # The controller's application is slower than the host's timeout and gap (a busy
    # simulator). The host's RST for AC and its next request, BA, wait in the controller's
    # backlog; when the application answers AC at last, the held input shows that the host has
    # moved on, so AC's answer is not sent (were it sent, the host, waiting for BA, would take
    # it as BA's answer). With the RST lost, BA alone shows it.
    pair = Pair()
    pair.request(AC)
    if rst_lost:
        pair.now = 2.0
        pair.host_events += pair.host.handle_timeout(2.0)
        assert pair.host.data_to_send() == RST_B  # lost
    else:
        pair.at(2.0)
    pair.request(BA)
    pair.at(2.25)
    host, ctl = pair.take()
    assert [(f.reason, f.state) for f in failures(host)] == [
        (FailReason.TIMEOUT, State.WAIT_ANSWER)
    ]
    assert ctl == [RequestReceived(AC), PeerMovedOn(State.HANDLING)]
    assert pair.to_ctl == ([frame(AC), frame(BA)] if rst_lost else [frame(AC), RST_B, frame(BA)])
    assert pair.host.state is State.WAIT_ANSWER
    pair.now = 2.3
    pair.answer([STALE])  # AC's answer, late
    assert pair.ctl.state is State.HANDLING
    pair.answer([OK])  # BA's answer
    host, ctl = pair.take()
    assert pair.to_host == [frame(OK)]
    assert host == [AnswerReceived(OK, 0x30, final=True), ExchangeComplete()]
    cancelled = (
        ExchangeFailed(FailReason.SUPERSEDED, State.HANDLING, "a new request came first")
        if rst_lost
        else ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED)
    )
    assert ctl == [cancelled, RequestReceived(BA), ExchangeComplete()]
    assert pair.host.idle and pair.ctl.idle


def test_a_held_rst_does_not_discard_the_start_of_a_later_frame() -> None:
    # An RST byte is only read between frames, so nothing of the exchange it ends is left
    # unfinished in the decoder. Held for the application's turn, the RST is acted on at the
    # application's call, when the start of the host's next request may have arrived: that
    # start is kept, and the request is taken whole when its end arrives.
    ctl = ControllerLink()
    assert ctl.receive_data(frame(AA), 0.0) == [RequestReceived(AA)]
    assert ctl.receive_data(RST_B, 0.1) == [PeerMovedOn(State.HANDLING)]
    request = frame(BA)
    assert ctl.receive_data(request[:3], 0.4) == []
    assert ctl.send_answer([AA_ANSWER], After.DONE, 0.5) == [
        ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED)
    ]
    assert ctl.data_to_send() == b""
    assert ctl.receive_data(request[3:], 0.6) == [RequestReceived(BA)]


@pytest.mark.parametrize(
    ("setup", "state"),
    [
        (SETUPS[(Role.CONTROLLER, State.WAIT_ACK)], State.WAIT_ACK),
        (SETUPS[(Role.HOST, State.WAIT_ANSWER)], State.WAIT_ANSWER),
    ],
    ids=["controller", "host"],
)
def test_an_rst_read_with_the_start_of_a_frame_keeps_that_start(
    setup: Callable[[], Link], state: State
) -> None:
    # The same without a hold: the RST is taken at once, and the start of the next frame read
    # with it stays in the decoder.
    link = setup()
    request = frame(BA)
    assert link.receive_data(RST_B + request[:3], T0 + 0.1) == [
        ExchangeFailed(FailReason.RESET, state, "RST received")
    ]
    assert link.data_to_send() == b""
    assert link.idle
    events = link.receive_data(request[3:], T0 + 0.2)
    if isinstance(link, ControllerLink):
        assert events == [RequestReceived(BA)]
    else:
        # The idle host takes it as a stale packet and stops it: proof the frame was read whole.
        assert events == [Ignored("stale packet outside an exchange (RST)", State.IDLE)]
        assert link.data_to_send() == RST_B


@pytest.mark.parametrize("stale", [FB_OK, b"\xff2"], ids=["resent reply", "stale refusal"])
def test_a_packet_behind_the_upload_reply_is_not_the_next_lines_reply(stale: bytes) -> None:
    # The controller sends nothing after an upload reply until the host's next packet, so a
    # packet read behind it (the reply resent on a NAK the host gave a noise frame, a stale
    # refusal) came before the next line and cannot be that line's reply. Held for the
    # application's turn, it breaks a rule at the line's call: RST in place of the line, never
    # a copy of the OK reply reporting the line accepted before the controller has read it, nor
    # the upload refused.
    host = HostLink()
    host.send_request(FB, Shape.UPLOAD, 0.0)
    host.data_to_send()
    assert host.receive_data(frame(FB_OK) + frame(stale), 0.1) == [UploadReady(FB_OK)]
    assert plain(host.send_upload_line(LINE_1, 0.2)) == [
        (
            ExchangeFailed(
                FailReason.RULE,
                State.UPLOAD_READY,
                "host link in state UPLOAD_READY cannot take packet: during our turn",
            ),
            ("host", "UPLOAD_READY", "packet"),
        )
    ]
    assert host.data_to_send() == RST_B
    assert host.state is State.RESYNC
    assert host.next_deadline() == pytest.approx(0.2 + GAP)


def test_an_empty_packet_on_a_fresh_idle_host_is_stale_not_a_resend() -> None:
    # Nothing was ACKed yet, so nothing can be resent: an empty packet is line debris.
    host = HostLink()
    events = host.receive_data(frame(b""), T0)
    assert events == [Ignored("stale packet outside an exchange (RST)", State.IDLE)]
    assert host.data_to_send() == RST_B
    assert host.idle and host.next_deadline() is None


# ===============================================================================================
# Bounds no peer can stretch (issue #11): announced waits, answer length, the overall limit
# ===============================================================================================
def test_an_announced_wait_is_capped_at_max_wait() -> None:
    host = HostLink(max_wait=5.0)
    host.send_request(DB, Shape.TWO_PHASE, 0.0)
    host.receive_data(frame(b"099"), 0.1)
    assert host.state is State.WAIT_SECOND
    assert host.next_deadline() == pytest.approx(0.1 + 5.0 + 2.0 + 0.5)


def test_max_wait_never_exceeds_what_two_digits_can_say() -> None:
    assert HostLink(max_wait=1000.0).max_wait == 99.0


@pytest.mark.parametrize("body", [b"0 5", b"005", b"05 "], ids=repr)
def test_an_announced_wait_takes_one_or_two_digits_and_spaces(body: bytes) -> None:
    host = HostLink()
    host.send_request(DB, Shape.TWO_PHASE, 0.0)
    events = host.receive_data(frame(body), 0.0)
    assert not failures(events)
    assert host.next_deadline() == pytest.approx(5.0 + 2.0 + 0.5)


def test_a_multi_packet_answer_is_cut_with_rst_past_max_packets() -> None:
    host = HostLink()
    host.send_request(AB, Shape.MULTI, 0.0, max_packets=3)
    host.data_to_send()
    events: list[LinkEvent] = []
    for k in range(4):
        events += host.receive_data(frame(ALARM_1), 0.01 * k)
    assert answers(events) == [ALARM_1] * 3
    [failed] = failures(events)
    assert failed.reason is FailReason.TOO_LONG
    assert "4 packets" in failed.detail
    assert host.data_to_send() == ACK_B * 3 + RST_B
    assert host.state is State.RESYNC


def test_no_peer_behaviour_stretches_an_exchange_past_its_limit() -> None:
    # Resends of the last answer, noise and NAKs each restart a wait; none goes past the limit
    # set when the request went out.
    host = HostLink(timeout=1.0, resend_grace=0.5)
    host.send_request(AA, Shape.SINGLE, 0.0)
    limit = 0.0 + 1.0 * (MAX_NAKS + 1) + (1.0 + 0.5) * 1
    now = 0.0
    while host.busy:
        now += 0.9
        deadline = host.next_deadline()
        assert deadline is not None and deadline <= limit + 1e-9
        if now >= deadline:
            host.handle_timeout(deadline)
            break
        host.receive_data(BAD_LRC, now)  # a damaged frame: NAKed, the wait restarts
        host.data_to_send()
    assert now < limit + 1.0


def test_a_reads_copy_taken_for_a_resend_is_its_answer_if_nothing_else_comes() -> None:
    # The controller answers the same request with the same bytes, but only after 1.9 s (near
    # its own 2 s resend time): it looks like a resend, and nothing else comes; a read takes it.
    host = _answered_then(0.1)
    host.data_to_send()
    assert host.receive_data(frame(AA_ANSWER), 2.0) == [
        Ignored("resent answer (ACKed again)", State.WAIT_ANSWER)
    ]
    deadline = host.next_deadline()
    assert deadline is not None
    assert host.handle_timeout(deadline) == [
        AnswerReceived(AA_ANSWER, 0x30, final=True),
        ExchangeComplete(),
    ]


def test_a_state_changes_copy_taken_for_a_resend_is_never_its_answer() -> None:
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    host.receive_data(frame(OK), 0.1)
    host.send_request(b"\xffCB00040", Shape.SINGLE, 0.1, once=True)
    host.data_to_send()
    host.receive_data(frame(OK), 2.1)
    deadline = host.next_deadline()
    assert deadline is not None
    [failed] = failures(host.handle_timeout(deadline))
    assert failed.reason is FailReason.TIMEOUT


@pytest.mark.parametrize("once", [False, True], ids=["a read", "a state change"])
def test_a_doubled_nak_in_one_read_brings_one_resend(once: bool) -> None:
    host = HostLink()
    host.send_request(b"\xffCB00040", Shape.SINGLE, 0.0, once=once)
    sent = host.data_to_send()
    events = host.receive_data(NAK_B + NAK_B, 0.01)
    assert len(events) == 1 and isinstance(events[0], Ignored)
    assert host.data_to_send() == sent  # one copy


def test_a_reads_second_nak_after_its_resend_went_out_brings_another() -> None:
    host = HostLink()
    host.send_request(AA, Shape.SINGLE, 0.0)
    sent = host.data_to_send()
    host.receive_data(NAK_B, 0.01)
    assert host.data_to_send() == sent
    host.receive_data(NAK_B, 0.02)
    assert host.data_to_send() == sent


def test_a_state_changes_second_nak_after_its_resend_brings_no_copy() -> None:
    host = HostLink()
    host.send_request(b"\xffCB00040", Shape.SINGLE, 0.0, once=True)
    sent = host.data_to_send()
    host.receive_data(NAK_B, 0.01)
    assert host.data_to_send() == sent
    events = host.receive_data(NAK_B, 0.02)
    assert events == [
        Ignored("NAK after our resend of a state change: not resent", State.WAIT_ANSWER)
    ]
    assert host.data_to_send() == b""
    deadline = host.next_deadline()
    assert deadline == pytest.approx(0.01 + 2.0)  # the ignored NAK restarts nothing
    [failed] = failures(host.handle_timeout(deadline))
    assert "not resent" in failed.detail


def test_an_upload_line_is_resent_once_for_a_nak_storm() -> None:
    host = HostLink()
    host.send_request(FB, Shape.UPLOAD, 0.0)
    sent = host.data_to_send()
    for k in range(1, 5):
        host.receive_data(NAK_B, 0.01 * k)
        assert host.data_to_send() == (sent if k == 1 else b"")
    deadline = host.next_deadline()
    assert deadline is not None
    [failed] = failures(host.handle_timeout(deadline))
    assert failed.reason is FailReason.TIMEOUT


def test_a_flooding_host_cannot_make_the_controller_hold_unbounded_input() -> None:
    """Requests sent behind the one being handled are held up to MAX_BACKLOG frames; the rest
    are dropped and counted, as a UART with a full buffer loses what comes next."""
    ctl = ControllerLink()
    request = encode_packet(AA)
    assert ctl.receive_data(request, 0.0) == [RequestReceived(AA)]
    ctl.receive_data(request * (MAX_BACKLOG + 500), 0.0)  # while the application has its turn
    assert ctl.overrun_frames == 500
    ctl.receive_data(request * 10, 0.0)
    assert ctl.overrun_frames == 510
    assert len(ctl._backlog) == MAX_BACKLOG


def test_a_line_that_never_goes_quiet_cannot_hold_a_request_for_ever() -> None:
    """Each stale packet in the resync gap restarts it, but the resync ends at the latest when
    a controller resending an unacknowledged answer would have given up."""
    host = HostLink(timeout=1.0, resync_gap=1.0)
    host.send_request(AA, Shape.SINGLE, 0.0)
    host.data_to_send()
    host.handle_timeout(1.0)  # no answer: RST, then the gap
    assert host.data_to_send() == bytes((RST,)) and host.state is State.RESYNC
    host.send_request(b"\xffAB", Shape.SINGLE, 1.0)  # deferred until the line is quiet
    now = 1.0
    cap = 1.0 + (MAX_RESENDS + 1) * 1.0 + host.resend_grace
    while host.state is State.RESYNC:
        now = round(now + 0.3, 3)
        assert now <= cap + 0.3, "the request was held past the cap"
        host.receive_data(encode_packet(b"\x30"), now)  # chatter: restarts the gap
        host.handle_timeout(now)
    assert host.state is State.WAIT_ANSWER
    assert now == pytest.approx(cap, abs=0.31)


def test_a_controller_aborting_after_its_host_moved_on_sends_no_rst() -> None:
    # The application's abort in its turn follows the rule its answer does: a host that gave
    # the exchange up is not sent an RST, which would land on its next request (taken there
    # as refused while that request is served next: retried, it would run twice).
    ctl = ControllerLink()
    assert ctl.receive_data(frame(AA), 0.0) == [RequestReceived(AA)]
    assert ctl.receive_data(frame(AB), 0.1) == [PeerMovedOn(State.HANDLING)]
    failed, taken = ctl.abort(0.2)
    assert isinstance(failed, ExchangeFailed) and failed.reason is FailReason.SUPERSEDED
    assert taken == RequestReceived(AB)  # the new request is served next
    assert ctl.data_to_send() == b""
    ctl = ControllerLink()
    ctl.receive_data(frame(AA), 0.0)
    ctl.receive_data(RST_B, 0.1)
    assert ctl.abort(0.2) == [ExchangeFailed(FailReason.RESET, State.HANDLING, CANCELLED)]
    assert ctl.data_to_send() == b"" and ctl.idle
    # with nothing from the host, the abort is an RST as before
    ctl = ControllerLink()
    ctl.receive_data(frame(AA), 0.0)
    assert ctl.abort(0.1)[0].reason is FailReason.ABORTED
    assert ctl.data_to_send() == RST_B
