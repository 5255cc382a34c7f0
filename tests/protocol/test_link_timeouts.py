"""Timers: the host's reply timeout (RST, nothing before the deadline), an upload's wait for the
final ACK, the controller's upload stall, and the controller's resends of an unACKed answer
(three, configurable, NAK resends not counted)."""

from __future__ import annotations

import pytest

from robostar.protocol.link import (
    MAX_RESENDS,
    After,
    ControllerLink,
    FailReason,
    HostLink,
    State,
)
from robostar.protocol.packets import Shape

from .link_pair import (
    AA,
    AA_ANSWER,
    AB,
    ALARM_1,
    ALARM_2,
    END,
    FB,
    FB_OK,
    NAK_B,
    RST_B,
    Pair,
    failures,
    frame,
)


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
