"""File uploads (FB) through the link: the controller's reply to the request, each line and the
END packet ACKed, a refusal at once or mid-upload, and a new request superseding an upload."""

from __future__ import annotations

from robostar.protocol.link import (
    After,
    AnswerReceived,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    RequestReceived,
    State,
    UploadPacketReceived,
    UploadReady,
)
from robostar.protocol.packets import Shape

from .link_pair import (
    AA,
    ACK_B,
    FB,
    FB_OK,
    LINE_1,
    LINE_2,
    RST_B,
    Pair,
    failures,
    frame,
)


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
