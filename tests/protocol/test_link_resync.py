"""The host's resync: after every RST it sends, the host stays quiet for ``resync_gap``, answering
any intact packet with RST and restarting the gap, so that a stale answer meets RST instead of
landing on the next request; requests made meanwhile wait for a whole quiet gap."""

from __future__ import annotations

import pytest

from robostar.errors import LinkRuleError, PacketTooLongError
from robostar.protocol.link import (
    MAX_NAKS,
    TRANSITIONS,
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    HostLink,
    Ignored,
    Input,
    Link,
    LinkEvent,
    RequestReceived,
    Role,
    State,
)
from robostar.protocol.packets import Shape

from .link_pair import (
    AA,
    AA_ANSWER,
    AB,
    AC,
    ACK_B,
    ALARM_1,
    ALARM_2,
    BA,
    BAD_LRC,
    DB,
    END,
    FB,
    FB_OK,
    GAP,
    LINE_1,
    NAK_B,
    OK,
    RST_B,
    SETUPS,
    STALE,
    T0,
    Pair,
    failures,
    frame,
)

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


# ===============================================================================================
# In the gap: intact packets, control bytes and damaged frames
# ===============================================================================================
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


# ===============================================================================================
# Requests made during the gap
# ===============================================================================================
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
