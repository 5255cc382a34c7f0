"""NAKs, damaged frames and RST: each end resends the same bytes on a NAK, three NAKs or damaged
frames in a row are resends and the fourth is an RST, frames cut short or overlong, and either
end's abort (RST) returning both to idle."""

from __future__ import annotations

import pytest

from robostar.protocol.link import (
    MAX_NAKS,
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
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
    BAD_LRC,
    DB,
    DB_FIRST,
    END,
    FB,
    FB_OK,
    LINE_1,
    NAK_B,
    OK,
    RST_B,
    Pair,
    answers,
    completes,
    failures,
    frame,
)


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
