"""Lost ACKs and resends: a copy of an answer the host already took is ACKed again and never
delivered twice or taken for the next request's answer; a new request supersedes an exchange the
controller is still in; the idle host's handling of copies, stale packets and stray bytes; the
resend grace after each non-final packet; and which copies and NAKs bring a resend (a read may
take a copy as its answer, a state change never)."""

from __future__ import annotations

import pytest

from robostar.errors import LinkRuleError
from robostar.protocol.link import (
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    HostLink,
    Ignored,
    RequestReceived,
    State,
)
from robostar.protocol.packets import Shape

from .link_pair import (
    AA,
    AA_ANSWER,
    AB,
    ACK_B,
    ALARM_1,
    ALARM_2,
    BA,
    DB,
    DB_FIRST,
    END,
    FB,
    NAK_B,
    OK,
    RST_B,
    T0,
    Pair,
    answers,
    completes,
    failures,
    frame,
)


# ===============================================================================================
# Lost ACKs: a copy is ACKed again, never delivered twice
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


# ===============================================================================================
# A new request supersedes the exchange the controller is still in
# ===============================================================================================
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


# ===============================================================================================
# The idle host: copies of its last answer, stale packets, stray bytes
# ===============================================================================================
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
    host.receive_data(frame(ALARM_1), 0.1)
    host.receive_data(frame(END), 0.1)  # sent after our ACK of ALARM_1, so in a read of its own
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


def test_an_empty_packet_on_a_fresh_idle_host_is_stale_not_a_resend() -> None:
    # Nothing was ACKed yet, so nothing can be resent: an empty packet is line debris.
    host = HostLink()
    events = host.receive_data(frame(b""), T0)
    assert events == [Ignored("stale packet outside an exchange (RST)", State.IDLE)]
    assert host.data_to_send() == RST_B
    assert host.idle and host.next_deadline() is None


# ===============================================================================================
# Resends on a faulty line: the application sends its next request at once after a failed
# exchange, and the link takes it
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
# Copies taken for resends, and NAKs: a read may take a copy as its answer, a state change
# never; one resend per NAK that may be its own
# ===============================================================================================
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
