"""Rules the peer breaks and the application's own mistakes: packets no exchange allows end it
with a broken rule (RST), and the application's calls in the wrong state or with bad packets are
refused before anything reaches the wire."""

from __future__ import annotations

import pytest

from robostar.errors import LinkRuleError, PacketTooLongError, UsageError
from robostar.protocol.link import (
    After,
    ControllerLink,
    FailReason,
    HostLink,
    State,
)
from robostar.protocol.packets import Shape

from .link_pair import (
    AA,
    AB,
    ACK_B,
    ALARM_1,
    END,
    FB,
    FB_OK,
    LINE_1,
    NAK_B,
    RST_B,
    answers,
    failures,
    frame,
)


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
