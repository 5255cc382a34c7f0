"""The peer moving on during the application's turn: an answer to a request the host gave up never
lands on its next request, an RST read with the start of a frame keeps that start, a packet read
behind an upload reply is not the next line's reply, and a controller whose host moved on sends
no RST when its application aborts."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from robostar.protocol.link import (
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    HostLink,
    Ignored,
    Link,
    PeerMovedOn,
    RequestReceived,
    Role,
    State,
    UploadReady,
)
from robostar.protocol.packets import Shape

from .link_pair import (
    AA,
    AA_ANSWER,
    AB,
    AC,
    BA,
    CANCELLED,
    FB,
    FB_OK,
    GAP,
    LINE_1,
    OK,
    RST_B,
    SETUPS,
    STALE,
    T0,
    Pair,
    failures,
    frame,
    plain,
)


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
