"""The application's turn: line input that arrives while the application prepares its answer (or
its next upload line) is held until its next call. An RST or a packet among it shows that the
peer moved on, and the call then sends nothing; noise meets the call's packet as usual."""

from __future__ import annotations

import pytest

from robostar.protocol.link import (
    After,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    HostLink,
    Ignored,
    LinkEvent,
    PeerMovedOn,
    RequestReceived,
    State,
    UploadPacketReceived,
    UploadReady,
)
from robostar.protocol.packets import Shape

from .link_pair import (
    AA,
    AA_ANSWER,
    AB,
    ACK_B,
    ALARM_1,
    BAD_LRC,
    CANCELLED,
    END,
    FB,
    FB_OK,
    GAP,
    LINE_1,
    NAK_B,
    OK,
    RST_B,
    frame,
    plain,
)


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


# ===============================================================================================
# Uploads: input held behind the END packet and behind the upload reply
# ===============================================================================================
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
            0.2 + 0.25,  # the default resync gap (GAP)
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
