"""A multi-packet answer whose controller is out of step with the host's ACKs is never taken
with a line lost or doubled. A frame that comes right behind another in one read (before the
host could answer the first), or right behind bytes that were no whole frame, shows a
controller running a packet ahead of the ACKs (it took a doubled ACK byte for two): the
exchange is given up rather than NAKed into the wrong packet. A copy of the last packet with a
frame behind it is a repeat where no two packets are equal (FD: not data, not ACKed), and
undecidable where they may be (FA, AB: given up). The same copy rule holds for FB's replies.
A controller in step (equal packets each after its ACK, a resend after a lost frame) is
untouched. (Issue 30: an FA download of a JOB file answered ("MAIN", "MAIN", "EOP") for
("MAIN", "DELAY 512", "EOP"), its line count still right.)"""

from __future__ import annotations

from robostar import Client
from robostar.commands import files
from robostar.protocol.frame import ACK, NAK, encode_packet
from robostar.protocol.link import (
    After,
    ControllerLink,
    ExchangeComplete,
    FailReason,
    HostLink,
    Ignored,
    State,
    UploadReady,
)
from robostar.protocol.packets import Shape
from robostar.sim import SimConfig
from robostar.sim.controller import VirtualController
from robostar.sim.faults import FaultInjector
from robostar.transport import PeerTransport

from .link_pair import ACK_B, END, FB, NAK_B, Pair, answers, completes, failures, frame

FA = b"\xffFA10     H5.JOB0"
ANNOUNCE = b"00003"
MAIN = b"0MAIN\n"
DELAY = b"0DELAY 512\n"
EOP = b"0EOP\n"
FILE = [ANNOUNCE, MAIN, DELAY, EOP, END]


def damaged(data: bytes) -> bytes:
    """The frame of ``data`` with its LRC spoiled (a byte lost or changed on the line)."""
    framed = frame(data)
    return framed[:-1] + bytes((framed[-1] ^ 0x55,))


def _download() -> Pair:
    """An FA exchange whose first packet (the announcement) the host has taken and ACKed; the
    controller's next packet (MAIN) is in its output, not yet on the line."""
    pair = Pair()
    pair.request(FA, Shape.MULTI)
    pair.ctl_events += pair.ctl.send_answer(FILE, After.DONE, 0.0)
    pair.host_events += pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    ack = pair.host.data_to_send()
    assert ack == ACK_B
    pair.ctl_events += pair.ctl.receive_data(ack, 0.0)
    return pair


def test_a_copy_with_a_damaged_frame_behind_it_gives_an_answer_with_equal_packets_up() -> None:
    # The announcement again, then MAIN damaged, in one read. A repeat of the announcement
    # (then ACKing it would count for MAIN, and the NAK would bring DELAY), or a controller
    # running a packet ahead sending two equal packets: which, nothing tells, so nothing of it
    # is taken.
    pair = _download()
    main = pair.ctl.data_to_send()
    assert main == frame(MAIN)
    events = pair.host.receive_data(frame(ANNOUNCE) + damaged(MAIN), 0.0)
    (failure,) = failures(events)
    assert failure.reason is FailReason.OUT_OF_STEP and "ahead of our ACKs" in failure.detail
    assert answers(events) == []
    sent = pair.host.data_to_send()
    assert ACK not in sent and NAK not in sent


def test_a_copy_with_a_frame_begun_behind_it_in_the_same_read_gives_it_up_too() -> None:
    pair = _download()
    main = pair.ctl.data_to_send()
    events = pair.host.receive_data(frame(ANNOUNCE) + main[:3], 0.0)
    assert [f.reason for f in failures(events)] == [FailReason.OUT_OF_STEP]
    assert answers(events) == []


def test_where_no_two_packets_are_equal_a_copy_with_a_damaged_frame_behind_is_a_repeat() -> None:
    # FD: every packet names its file, so the copy is a repeat: not data, not ACKed, and the
    # NAK of the damaged frame brings that very frame again.
    pair = Pair()
    listing = [b"0A.JOB", b"0B.JOB", b"0C.JOB", END]
    pair.host_events += pair.host.send_request(b"\xffFD10*", Shape.MULTI, 0.0, distinct=True)
    pair.pump()
    pair.ctl_events += pair.ctl.send_answer(listing, After.DONE, 0.0)
    pair.host_events += pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    pair.ctl_events += pair.ctl.receive_data(pair.host.data_to_send(), 0.0)
    assert pair.ctl.data_to_send() == frame(listing[1])
    events = pair.host.receive_data(frame(listing[0]) + damaged(listing[1]), 0.0)
    assert Ignored("a repeat of the last packet, sent without waiting", State.WAIT_MORE) in events
    assert pair.host.data_to_send() == NAK_B  # no ACK for the copy: it would count for B.JOB
    pair.host_events += events
    pair.ctl_events += pair.ctl.receive_data(NAK_B, 0.0)
    pair.pump()
    host, ctl = pair.take()
    assert answers(host) == listing
    assert completes(host) == completes(ctl) == 1


def test_a_frame_right_behind_bytes_that_were_no_frame_gives_the_exchange_up() -> None:
    # A controller a packet ahead sent MAIN and DELAY back to back, and MAIN lost its STX:
    # DELAY alone must not pass for MAIN's successor.
    host = HostLink()
    host.send_request(FA, Shape.MULTI, 0.0)
    host.data_to_send()
    host.receive_data(frame(ANNOUNCE), 0.0)
    host.data_to_send()
    events = host.receive_data(frame(MAIN)[1:] + frame(DELAY), 0.0)
    (failure,) = failures(events)
    assert failure.reason is FailReason.OUT_OF_STEP and answers(events) == []


def test_a_frame_cutting_one_short_in_the_same_read_gives_the_exchange_up() -> None:
    host = HostLink()
    host.send_request(FA, Shape.MULTI, 0.0)
    host.data_to_send()
    host.receive_data(frame(ANNOUNCE), 0.0)
    host.data_to_send()
    events = host.receive_data(frame(MAIN)[:-2] + frame(DELAY), 0.0)
    (failure,) = failures(events)
    assert failure.reason is FailReason.OUT_OF_STEP and answers(events) == []


def test_a_resend_cutting_short_a_frame_of_an_earlier_read_is_taken() -> None:
    # In step: MAIN lost its end, the controller resends it after its timeout, in a read of
    # its own. That is the usual recovery, not a controller ahead.
    host = HostLink()
    host.send_request(FA, Shape.MULTI, 0.0)
    host.data_to_send()
    host.receive_data(frame(ANNOUNCE), 0.0)
    host.data_to_send()
    assert host.receive_data(frame(MAIN)[:-2], 0.1) == []
    events = host.receive_data(frame(MAIN), 2.1)
    assert answers(events) == [MAIN] and failures(events) == []


def test_noise_then_a_packet_in_a_read_of_its_own_after_a_resend_is_taken() -> None:
    # In step: MAIN lost its STX (noise), the controller resends it after its timeout.
    host = HostLink()
    host.send_request(FA, Shape.MULTI, 0.0)
    host.data_to_send()
    host.receive_data(frame(ANNOUNCE), 0.0)
    host.data_to_send()
    assert answers(host.receive_data(frame(MAIN)[1:], 0.1)) == []
    events = host.receive_data(frame(MAIN), 2.1)
    assert answers(events) == [MAIN] and failures(events) == []


def test_a_frame_behind_a_packet_before_our_ack_of_it_gives_the_exchange_up() -> None:
    # Our ACK of the announcement reaches the controller doubled: it takes the second byte for
    # the ACK of MAIN and sends DELAY right behind it, and DELAY arrives damaged. A NAK would
    # bring EOP (the controller's packet in hand), and the file would lose DELAY.
    pair = Pair()
    pair.request(FA, Shape.MULTI)
    pair.ctl_events += pair.ctl.send_answer(FILE, After.DONE, 0.0)
    pair.host_events += pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    assert pair.host.data_to_send() == ACK_B
    pair.ctl_events += pair.ctl.receive_data(bytes((ACK, ACK)), 0.0)  # the line doubles it
    both = pair.ctl.data_to_send()
    assert both == frame(MAIN) + frame(DELAY)  # sent without waiting for our ACK of MAIN
    events = pair.host.receive_data(frame(MAIN) + damaged(DELAY), 0.0)
    (failure,) = failures(events)
    assert failure.reason is FailReason.OUT_OF_STEP and "ahead of our ACKs" in failure.detail
    assert answers(events) == []
    assert NAK not in pair.host.data_to_send()


def test_an_intact_frame_behind_a_packet_before_our_ack_gives_the_exchange_up_too() -> None:
    # The same controller a packet ahead, nothing damaged yet: from here any damaged or lost
    # frame would cost a line unseen, so the answer is not taken.
    pair = Pair()
    pair.request(FA, Shape.MULTI)
    pair.ctl_events += pair.ctl.send_answer(FILE, After.DONE, 0.0)
    pair.host_events += pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    pair.host.data_to_send()
    pair.ctl_events += pair.ctl.receive_data(bytes((ACK, ACK)), 0.0)
    events = pair.host.receive_data(pair.ctl.data_to_send(), 0.0)
    (failure,) = failures(events)
    assert failure.reason is FailReason.OUT_OF_STEP
    assert not any(isinstance(e, ExchangeComplete) for e in events)


def test_a_damaged_frame_with_a_frame_behind_it_gives_the_exchange_up() -> None:
    # Ahead of our ACKs, the first of the two arrives damaged: NAKing it would bring the
    # second again, and the damaged one would never come.
    host = HostLink()
    host.send_request(FA, Shape.MULTI, 0.0)
    host.data_to_send()
    host.receive_data(frame(ANNOUNCE), 0.0)
    host.data_to_send()
    events = host.receive_data(damaged(MAIN) + frame(DELAY), 0.0)
    (failure,) = failures(events)
    assert failure.reason is FailReason.OUT_OF_STEP and failure.state is State.WAIT_MORE
    assert NAK not in host.data_to_send()


def test_equal_packets_each_in_a_read_of_its_own_are_still_data() -> None:
    # Two equal lines of a JOB, each sent after our ACK of the one before: the rule above does
    # not touch a controller in step.
    pair = Pair()
    pair.request(FA, Shape.MULTI)
    pair.answer([b"00003", MAIN, MAIN, EOP, END])
    host, _ = pair.take()
    assert answers(host) == [b"00003", MAIN, MAIN, EOP, END]
    assert failures(host) == []


def test_a_copy_of_an_upload_reply_with_a_damaged_frame_behind_it_accepts_nothing() -> None:
    host = HostLink()
    host.send_request(FB, Shape.UPLOAD, 0.0)
    host.data_to_send()
    reply = b"\xff0"
    assert host.receive_data(frame(reply), 0.0) == [UploadReady(reply)]
    host.send_upload_line(b"MAIN\n", 0.0)
    host.data_to_send()
    events = host.receive_data(frame(reply) + damaged(reply), 0.0)
    assert Ignored("a repeat of the last reply, sent without waiting", State.UPLOAD_WAIT_REPLY) in (
        events
    )
    assert not any(isinstance(e, UploadReady) for e in events)
    assert host.state is State.UPLOAD_WAIT_REPLY


def test_a_controller_link_resends_for_a_nak_what_it_holds() -> None:
    # What makes the rules above needed: the controller's NAK resend is of its packet in hand,
    # which a doubled ACK has moved one on.
    ctl = ControllerLink()
    ctl.receive_data(frame(FA), 0.0)
    ctl.send_answer(FILE, After.DONE, 0.0)
    ctl.data_to_send()
    ctl.receive_data(bytes((ACK, ACK)), 0.0)
    assert ctl.data_to_send() == frame(MAIN) + frame(DELAY)
    ctl.receive_data(NAK_B, 0.0)
    assert ctl.data_to_send() == frame(DELAY)


def test_a_download_through_a_doubled_ack_and_a_damaged_line_gets_the_right_file() -> None:
    # End to end, on the simulator: the client's ACK of the announcement doubled on its way,
    # a byte of DELAY's packet lost. The controller runs a packet ahead, and a NAK of the
    # damaged DELAY brought EOP twice: ("MAIN", "EOP", "EOP"), three lines as announced. The
    # client gives that answer up and asks again.
    controller = VirtualController(SimConfig())
    line = FaultInjector(controller, seed=1)
    lines = ("MAIN", "DELAY 512", "EOP")
    download = files.DownloadFile(1, "H5.JOB")
    with Client(PeerTransport(line)) as client:
        client.execute(files.UploadFile(1, "H5.JOB", 0, lines))
        request = len(encode_packet(download.encode()))
        line.schedule("dup", "to_controller", at_byte=request)  # our ACK of the announcement
        line.schedule("drop", "to_host", at_byte=9 + 10 + 4)  # in DELAY's packet
        before = controller.requests
        # given up once the controller is seen ahead, and asked again: the right file
        assert client.execute(download).lines == lines
        assert line.total() == 2
        assert controller.requests - before >= 2
