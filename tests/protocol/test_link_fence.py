"""The fence after an exchange the host gave up: the next request other than a stop waits
behind a read whose answer nothing else can pass for, and what arrives before that answer is
dropped. Driven by hand with explicit ``now`` values (timeout 2 s, quiet gap 0.25 s)."""

from __future__ import annotations

from robostar.protocol.frame import ACK, RST, encode_packet
from robostar.protocol.link import (
    AnswerReceived,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    Fence,
    HostLink,
    Ignored,
    LinkEvent,
    State,
)
from robostar.protocol.packets import Shape

AA, AA_ANSWER = b"\xffAA", b"0\x84\x84\x80"
AD, AD_ANSWER = b"\xffAD", b"\xff0INFO"
GR10, GR10_ANSWER = b"\xffGR0   10", b"0  1010"
GR20, GR20_ANSWER = b"\xffGR0   20", b"0  2020"
CF = b"\xffCF"
FENCES = (Fence(AA, lambda d: d == AA_ANSWER), Fence(AD, lambda d: d == AD_ANSWER))


def _given_up(request: bytes = GR10) -> HostLink:
    """A host whose ``request`` (sent at 0) timed out at 2: RST sent, quiet gap until 2.25."""
    host = HostLink(fences=FENCES)
    host.send_request(request, Shape.SINGLE, 0.0)
    [failed] = host.handle_timeout(2.0)
    assert isinstance(failed, ExchangeFailed)
    assert host.data_to_send() == encode_packet(request) + bytes((RST,))
    return host


def _answers(events: list[LinkEvent]) -> list[bytes]:
    return [e.data for e in events if isinstance(e, AnswerReceived)]


def test_the_next_request_waits_behind_the_fence_and_old_answers_are_dropped() -> None:
    host = _given_up()
    assert host.send_request(GR20, Shape.SINGLE, 3.0) == []
    assert host.data_to_send() == encode_packet(AA)  # the fence, not GR20
    assert host.state is State.WAIT_FENCE
    # g10's answer, late: dropped, not ACKed, and not taken for anything
    [ignored] = host.receive_data(encode_packet(GR10_ANSWER), 3.1)
    assert isinstance(ignored, Ignored) and "fence" in ignored.what
    assert host.data_to_send() == b""
    # the fence's answer: ACKed, and GR20 goes out at once
    assert host.receive_data(encode_packet(AA_ANSWER), 3.2) == []
    assert host.data_to_send() == bytes((ACK,)) + encode_packet(GR20)
    events = host.receive_data(encode_packet(GR20_ANSWER), 3.3)
    assert _answers(events) == [GR20_ANSWER] and isinstance(events[-1], ExchangeComplete)
    # the line is clean again: the request after it needs no fence
    host.data_to_send()
    host.send_request(GR10, Shape.SINGLE, 3.4)
    assert host.data_to_send() == encode_packet(GR10)


def test_a_new_call_of_the_same_read_is_fenced_a_retry_is_not() -> None:
    # A new call must not get a sample taken before it was asked; the rules' own retry of the
    # call whose answer was lost may take the late answer of its first try.
    host = _given_up()
    host.send_request(GR10, Shape.SINGLE, 3.0)
    assert host.data_to_send() == encode_packet(AA)
    host = _given_up()
    host.retry_next()
    host.send_request(GR10, Shape.SINGLE, 3.0)
    assert host.data_to_send() == encode_packet(GR10)
    assert host.state is State.WAIT_ANSWER


def test_a_stop_never_waits_for_the_fence() -> None:
    host = _given_up()
    host.send_request(CF, Shape.SINGLE, 3.0)
    assert host.data_to_send() == encode_packet(CF)


def test_after_a_given_up_status_read_the_other_fence_is_used() -> None:
    # A late AA answer could pass for an AA fence's: AD fences it off.
    host = _given_up(AA)
    host.send_request(GR20, Shape.SINGLE, 3.0)
    assert host.data_to_send() == encode_packet(AD)
    host.receive_data(encode_packet(AA_ANSWER), 3.1)  # the late one: dropped
    assert host.data_to_send() == b""
    host.receive_data(encode_packet(AD_ANSWER), 3.2)
    assert host.data_to_send() == bytes((ACK,)) + encode_packet(GR20)


def test_a_fence_without_an_answer_fails_the_request_unsent() -> None:
    host = _given_up()
    host.send_request(GR20, Shape.SINGLE, 3.0)
    host.data_to_send()
    [failed] = host.handle_timeout(5.0)
    assert isinstance(failed, ExchangeFailed)
    assert (failed.reason, failed.state) == (FailReason.TIMEOUT, State.WAIT_FENCE)
    assert "it was not sent" in failed.detail
    assert host.data_to_send() == bytes((RST,))
    # fenced again next time, with the other fence (the AA read is now the one given up)
    host.send_request(GR20, Shape.SINGLE, 6.0)
    assert host.data_to_send() == encode_packet(AD)
