"""Bounds no peer can stretch: announced waits are capped at ``max_wait``, a multi-packet answer
is cut past ``max_packets``, no peer behaviour keeps an exchange past its limit, a flooding host
cannot make the controller hold unbounded input, and a line that never goes quiet cannot hold a
request for ever."""

from __future__ import annotations

import pytest

from robostar.protocol.frame import RST, encode_packet
from robostar.protocol.link import (
    MAX_BACKLOG,
    MAX_NAKS,
    MAX_RESENDS,
    ControllerLink,
    FailReason,
    HostLink,
    LinkEvent,
    RequestReceived,
    State,
)
from robostar.protocol.packets import Shape

from .link_pair import (
    AA,
    AB,
    ACK_B,
    ALARM_1,
    BAD_LRC,
    DB,
    RST_B,
    answers,
    failures,
    frame,
)


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


# ===============================================================================================
# Input no peer can make unbounded
# ===============================================================================================
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
