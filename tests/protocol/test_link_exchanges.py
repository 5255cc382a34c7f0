"""Each exchange shape, byte by byte: a single answer, a multi-packet answer ACKed packet by
packet, a two-phase answer (DB, CE) with its announced wait, and error answers that end any
shape."""

from __future__ import annotations

import pytest

from robostar.protocol.link import (
    After,
    AnswerReceived,
    ExchangeComplete,
    FailReason,
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
    DB,
    DB_FIRST,
    END,
    OK,
    RST_B,
    Pair,
    answers,
    completes,
    failures,
    frame,
)


def test_single_exchange_bytes() -> None:
    pair = Pair()
    assert pair.host.send_request(AA, Shape.SINGLE, 0.0) == []
    request = pair.host.data_to_send()
    assert request == bytes.fromhex("02 FF 41 41 03 FF")
    assert pair.host.state is State.WAIT_ANSWER
    assert pair.host.next_deadline() == 2.0
    assert pair.ctl.receive_data(request, 0.0) == [RequestReceived(AA)]
    assert pair.ctl.state is State.HANDLING
    assert pair.ctl.next_deadline() is None
    assert pair.ctl.send_answer([AA_ANSWER], After.DONE, 0.1) == []
    answer = pair.ctl.data_to_send()
    assert answer == bytes.fromhex("02 30 B5 80 80 03 85")
    assert pair.ctl.next_deadline() == pytest.approx(2.1)
    assert pair.host.receive_data(answer, 0.1) == [
        AnswerReceived(AA_ANSWER, 0x30, final=True),
        ExchangeComplete(),
    ]
    assert pair.host.data_to_send() == ACK_B
    assert pair.host.idle and pair.host.next_deadline() is None
    assert pair.ctl.receive_data(ACK_B, 0.1) == [ExchangeComplete()]
    assert pair.ctl.idle and pair.ctl.next_deadline() is None
    assert pair.ctl.data_to_send() == b""


def test_a_dummy_byte_before_the_flag_is_accepted() -> None:
    pair = Pair()
    pair.request(b"\xffAD")
    pair.answer([b"\xff0" + b"3N1    V1.0"])
    host, ctl = pair.take()
    assert answers(host) == [b"\xff0" + b"3N1    V1.0"]
    assert host[0] == AnswerReceived(b"\xff03N1    V1.0", 0x30, final=True)
    assert completes(host) == completes(ctl) == 1


def test_multi_exchange_each_packet_after_the_previous_ack() -> None:
    pair = Pair()
    pair.host.send_request(AB, Shape.MULTI, 0.0)
    pair.ctl.receive_data(pair.host.data_to_send(), 0.0)
    pair.ctl.send_answer([ALARM_1, ALARM_2, END], After.DONE, 0.0)
    # Only the first packet goes out until the host ACKs it.
    assert pair.ctl.data_to_send() == frame(ALARM_1)
    assert pair.ctl.data_to_send() == b""
    assert pair.host.receive_data(frame(ALARM_1), 0.1) == [
        AnswerReceived(ALARM_1, 0x30, final=False)
    ]
    assert pair.host.state is State.WAIT_MORE
    # timeout + resend_grace after our ACK: a resend after the controller's own timeout is heard
    assert pair.host.next_deadline() == pytest.approx(0.1 + 2.0 + 0.5)
    assert pair.host.data_to_send() == ACK_B
    assert pair.ctl.receive_data(ACK_B, 0.1) == []
    assert pair.ctl.data_to_send() == frame(ALARM_2)
    assert pair.host.receive_data(frame(ALARM_2), 0.2) == [
        AnswerReceived(ALARM_2, 0x30, final=False)
    ]
    assert pair.host.next_deadline() == pytest.approx(0.2 + 2.0 + 0.5)
    assert pair.ctl.receive_data(pair.host.data_to_send(), 0.2) == []
    assert pair.ctl.data_to_send() == bytes.fromhex("02 34 03 34")
    assert pair.host.receive_data(frame(END), 0.3) == [
        AnswerReceived(END, 0x34, final=True),
        ExchangeComplete(),
    ]
    assert pair.host.data_to_send() == ACK_B  # END is ACKed too
    assert pair.ctl.receive_data(ACK_B, 0.3) == [ExchangeComplete()]
    assert pair.host.idle and pair.ctl.idle


def test_multi_exchange_of_only_an_end_packet() -> None:
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.answer([END])
    host, ctl = pair.take()
    assert answers(host) == [END]
    assert completes(host) == completes(ctl) == 1


def test_two_phase_db_waits_the_expected_time_plus_the_timeout_and_grace() -> None:
    pair = Pair()
    pair.request(DB, Shape.TWO_PHASE)
    pair.now = 0.5
    pair.answer([DB_FIRST], After.SECOND_PHASE)
    host, ctl = pair.take()
    assert host == [AnswerReceived(DB_FIRST, 0x30, final=False)]
    assert ctl == [RequestReceived(DB)]
    assert pair.to_host[-1] == frame(DB_FIRST)
    assert pair.to_ctl[-1] == ACK_B
    assert pair.host.state is State.WAIT_SECOND
    assert pair.host.next_deadline() == pytest.approx(0.5 + 2 + 2.0 + 0.5)
    assert pair.ctl.state is State.WORKING
    assert pair.ctl.next_deadline() is None
    # Nothing happens before the deadline, even past the expected wait plus the reply timeout.
    pair.at(4.99)
    assert pair.take() == ([], [])
    assert pair.host.state is State.WAIT_SECOND
    pair.now = 4.9
    pair.answer([OK])
    host, ctl = pair.take()
    assert host == [AnswerReceived(OK, 0x30, final=True), ExchangeComplete()]
    assert ctl == [ExchangeComplete()]
    assert pair.to_ctl[-1] == ACK_B


def test_two_phase_deadline_passes_without_a_second_answer() -> None:
    pair = Pair()
    pair.request(DB, Shape.TWO_PHASE)
    pair.answer([b"010"], After.SECOND_PHASE)
    assert pair.host.next_deadline() == pytest.approx(10.0 + 2.0 + 0.5)
    pair.take()
    pair.at(12.49)
    assert pair.take() == ([], [])
    pair.at(12.5)
    host, ctl = pair.take()
    assert [f.reason for f in failures(host)] == [FailReason.TIMEOUT]
    assert failures(host)[0].state is State.WAIT_SECOND
    assert [f.reason for f in failures(ctl)] == [FailReason.RESET]
    assert pair.to_ctl[-1] == RST_B
    assert pair.host.state is State.RESYNC
    assert pair.host.next_deadline() == pytest.approx(12.75)
    assert pair.ctl.idle
    pair.at(12.75)
    assert pair.take() == ([], [])
    assert pair.host.idle and pair.host.next_deadline() is None
    assert pair.to_ctl[-1] == RST_B  # the gap's end sends nothing


def test_two_phase_ce_takes_two_bare_flags_even_long_apart() -> None:
    pair = Pair()
    pair.request(b"\xffCE0", Shape.TWO_PHASE)
    pair.answer([OK], After.SECOND_PHASE)
    # CE's first answer has no wait: the deadline is the plain timeout and the resend grace.
    assert pair.host.next_deadline() == pytest.approx(2.0 + 0.5)
    pair.now = 1.5  # well past resend_gap: an equal packet is still the second answer
    pair.answer([OK])
    host, ctl = pair.take()
    assert host == [
        AnswerReceived(OK, 0x30, final=False),
        AnswerReceived(OK, 0x30, final=True),
        ExchangeComplete(),
    ]
    assert completes(ctl) == 1
    assert pair.to_ctl[-2:] == [ACK_B, ACK_B]


def test_two_phase_error_on_the_first_answer_ends_the_exchange() -> None:
    pair = Pair()
    pair.request(DB, Shape.TWO_PHASE)
    pair.answer([b"2"])
    host, ctl = pair.take()
    assert host == [AnswerReceived(b"2", 0x32, final=True), ExchangeComplete()]
    assert completes(ctl) == 1
    assert pair.to_ctl[-1] == ACK_B


@pytest.mark.parametrize("flag", [0x31, 0x32, 0x33])
@pytest.mark.parametrize("shape", [Shape.SINGLE, Shape.MULTI, Shape.TWO_PHASE])
def test_error_answers_are_acked_and_end_the_exchange(flag: int, shape: Shape) -> None:
    pair = Pair()
    pair.request(b"\xffCC0", shape)
    error = bytes((flag,))
    pair.answer([error])
    host, ctl = pair.take()
    assert host == [AnswerReceived(error, flag, final=True), ExchangeComplete()]
    assert completes(ctl) == 1
    assert pair.to_ctl[-1] == ACK_B


def test_error_flag_mid_multi_ends_it() -> None:
    pair = Pair()
    pair.request(AB, Shape.MULTI)
    pair.answer([ALARM_1, b"2"])
    host, ctl = pair.take()
    assert answers(host) == [ALARM_1, b"2"]
    assert host[-2] == AnswerReceived(b"2", 0x32, final=True)
    assert completes(host) == completes(ctl) == 1
    assert pair.to_ctl[1:] == [ACK_B, ACK_B]
