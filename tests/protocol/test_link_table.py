"""The link's transition table: every entry runs its handler, every (role, state, input) pair
the table leaves out breaks a rule or waits for the application's next call, and ``busy`` /
``idle`` in every state.

Each state is reached from a fresh link through its public interface (``SETUPS`` in
link_pair.py) and given each input by hand, with explicit ``now`` values.
"""

from __future__ import annotations

import pytest

from robostar.errors import LinkRuleError
from robostar.protocol.link import (
    APP_TURN,
    TRANSITIONS,
    After,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    HostLink,
    Ignored,
    Input,
    Link,
    LinkEvent,
    PeerMovedOn,
    RequestReceived,
    Role,
    State,
)
from robostar.protocol.packets import Shape

from .link_pair import (
    AA,
    AA_ANSWER,
    AB,
    ACK_B,
    ALARM_2,
    BAD_LRC,
    CANCELLED,
    END,
    FB_OK,
    LINE_2,
    NAK_B,
    OK,
    RST_B,
    SETUPS,
    T0,
    failures,
    frame,
    plain,
)

HOST_APP = frozenset((Input.SEND_REQUEST, Input.SEND_LINE, Input.SEND_END, Input.ABORT))
CTL_APP = frozenset((Input.SEND_ANSWER, Input.ACCEPT_UPLOAD, Input.ABORT))
LINE_INPUTS = frozenset(
    (Input.PACKET, Input.CORRUPT, Input.ACK, Input.NAK, Input.RST, Input.TIMEOUT)
)
APP_INPUTS = {Role.HOST: HOST_APP, Role.CONTROLLER: CTL_APP}


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
# busy and idle in every state
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
