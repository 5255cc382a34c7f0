"""The one-step read of a clean answer, pinned to the general rules.

:func:`~robostar.protocol.frame.lone_frame` must read a frame exactly as
:class:`~robostar.protocol.frame.FrameDecoder` does, and
:meth:`~robostar.protocol.link.HostLink.receive_clean_answer` must leave the link exactly as
:meth:`~robostar.protocol.link.HostLink.receive_data` does with the same bytes (or decline
and change nothing), for every kind of input: good answers, error flags, END, unknown flags,
damaged frames, copies of the last answer, control bytes around a frame, two frames in one
read, a frame begun in an earlier read.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.errors import PacketTooLongError
from robostar.protocol.frame import (
    ACK,
    ETX,
    NAK,
    RST,
    STX,
    FrameDecoder,
    Packet,
    encode_packet,
    lone_frame,
)
from robostar.protocol.link import AnswerReceived, ExchangeComplete, HostLink, Ignored, State
from robostar.protocol.packets import Shape

AA = b"\xffAA"
OK_ANSWER = b"0\xb5\x80\x80"
DUMMY_ANSWER = b"\xff0\xb5\x80\x80"


def _frames() -> list[bytes]:
    """Reads of every kind, framed and not."""
    good = [
        OK_ANSWER,
        DUMMY_ANSWER,
        b"0",
        b"\xff0",
        b"0" + b"1234567.890" * 4,
        b"0" + b"A" * 246,  # the longest packet
        b"00",  # LRC zero: sent as ETX
        b"\xff\xff",  # LRC zero, dummy and a flag of 0xFF
        b"1",
        b"2",
        b"3",
        b"\xff2",
        b"4",
        b"\xff4",
        b"9",  # unknown flag
        b"\xff",  # the dummy byte alone: no flag
        b"",  # no data at all
        b"0\x80",
    ]
    reads = [encode_packet(data) for data in good]
    aa = encode_packet(OK_ANSWER)
    reads += [
        aa[:-1] + bytes((aa[-1] ^ 1,)),  # bad LRC
        bytes((STX,)) + b"00" + bytes((ETX, 0)),  # zero LRC sent as 0x00: accepted
        bytes((STX,)) + b"00" + bytes((ETX, 1)),  # wrong LRC for a zero XOR
        bytes((ACK,)) + aa,
        bytes((NAK,)) + aa,
        bytes((RST,)) + aa,
        aa + bytes((ACK,)),
        aa + aa,
        aa + encode_packet(b"1"),
        aa[:-2],  # cut before ETX
        aa[:3],
        aa[1:],  # no STX
        b"x" + aa,  # noise before
        aa + b"x",  # noise after
        aa[:2] + bytes((STX,)) + aa[1:],  # a new STX inside: truncated, then a frame
        bytes((STX,)) + b"0" * 250 + bytes((ETX, 0)),  # too long
        bytes((ACK,)),
        bytes((NAK,)),
        bytes((RST,)),
        b"",
        bytes((STX, ETX, ETX)),
        bytes((STX, ETX)),
    ]
    return reads


READS = _frames()


def _decoder_state(decoder: FrameDecoder) -> tuple[object, ...]:
    return (bytes(decoder._buf), decoder._state, decoder.discarded)


@pytest.mark.parametrize("read", READS, ids=lambda r: r.hex(" ") or "empty")
def test_lone_frame_reads_as_the_decoder_does(read: bytes) -> None:
    _check_lone_frame(read)


@given(st.binary(max_size=300))
def test_lone_frame_reads_any_bytes_as_the_decoder_does(read: bytes) -> None:
    _check_lone_frame(read)


@given(st.binary(max_size=260).filter(lambda d: 2 not in d and 3 not in d), st.integers(0, 255))
def test_lone_frame_reads_any_frame_as_the_decoder_does(data: bytes, lrc_byte: int) -> None:
    _check_lone_frame(bytes((STX,)) + data + bytes((ETX, lrc_byte)))


def _check_lone_frame(read: bytes) -> None:
    decoder = FrameDecoder()
    events = decoder.feed(read)
    packet = lone_frame(read)
    if packet is not None:
        assert events == [Packet(packet)]
        assert decoder.between_frames
        assert decoder.pending == 0
        assert decoder.discarded == 0
    elif read[:1] == bytes((STX,)) and events == [Packet(read[1:-2])]:
        # The decoder read the bytes as one whole frame and nothing else: so must lone_frame
        # (unless a frame was left begun after it).
        assert not decoder.between_frames or decoder.discarded


# -- the link ---------------------------------------------------------------------------------
def _waiting(shape: Shape) -> Callable[[], HostLink]:
    def setup() -> HostLink:
        link = HostLink()
        link.send_request(AA, shape, 10.0)
        link.data_to_send()
        return link

    return setup


def _after_answer(gap: float) -> Callable[[], HostLink]:
    """A second SINGLE request after an exchange answered with OK_ANSWER (a copy of it may be
    the controller's resend)."""

    def setup() -> HostLink:
        link = HostLink()
        link.send_request(AA, Shape.SINGLE, 10.0)
        link.receive_data(encode_packet(OK_ANSWER), 10.0)
        link.send_request(AA, Shape.SINGLE, 10.0 + gap)
        link.data_to_send()
        return link

    return setup


def _after_nak() -> HostLink:
    link = _waiting(Shape.SINGLE)()
    link.receive_data(bytes((NAK,)), 10.1)
    return link


def _after_corrupt() -> HostLink:
    link = _waiting(Shape.SINGLE)()
    aa = encode_packet(OK_ANSWER)
    link.receive_data(aa[:-1] + bytes((aa[-1] ^ 1,)), 10.1)
    return link


def _frame_begun() -> HostLink:
    link = _waiting(Shape.SINGLE)()
    link.receive_data(encode_packet(OK_ANSWER)[:3], 10.1)
    return link


def _maybe_resent() -> HostLink:
    """A copy of the last answer, late enough to be taken for the controller's resend."""
    link = _after_answer(0.1)()
    link.receive_data(encode_packet(OK_ANSWER), 13.0)
    return link


def _idle() -> HostLink:
    return HostLink()


def _resync() -> HostLink:
    link = _waiting(Shape.SINGLE)()
    link.abort(10.1)
    return link


def _stop_after_abort(after: float) -> Callable[[], HostLink]:
    """A stop (CF) sent ``after`` s after our own abort: early (within the quiet gap, after
    ``abort_gap``), where an answer with data is stale and ignored; or once the gap is over,
    as any request."""

    def setup() -> HostLink:
        link = _waiting(Shape.SINGLE)()
        link.abort(10.1)
        link.data_to_send()
        link.send_request(b"\xffCF", Shape.SINGLE, 10.1 + after)
        link.handle_timeout(10.1 + after)
        assert link.data_to_send().endswith(encode_packet(b"\xffCF"))
        return link

    return setup


SETUPS: dict[str, Callable[[], HostLink]] = {
    "single": _waiting(Shape.SINGLE),
    "multi": _waiting(Shape.MULTI),
    "two-phase": _waiting(Shape.TWO_PHASE),
    "upload": _waiting(Shape.UPLOAD),
    "after an answer, at once": _after_answer(0.0),
    "after an answer, later": _after_answer(3.0),
    "after a NAK": _after_nak,
    "after a corrupt answer": _after_corrupt,
    "a frame begun": _frame_begun,
    "a copy taken for a resend": _maybe_resent,
    "idle": _idle,
    "resync": _resync,
    "an early stop": _stop_after_abort(0.06),
    "a stop after the whole gap": _stop_after_abort(100.0),
}


_MEMO = frozenset(("_clean_read", "_clean_packet"))
"""receive_clean_answer's memo of lone_frame (a pure function of the read): not link state."""


def _snapshot(link: HostLink) -> dict[str, Any]:
    state = {
        key: copy.copy(value)
        for key, value in vars(link).items()
        if key != "decoder" and key not in _MEMO
    }
    state["_out"] = bytes(link._out)
    state["decoder"] = _decoder_state(link.decoder)
    return state


@pytest.mark.parametrize("later", [0.05, 2.5])
@pytest.mark.parametrize("name", list(SETUPS))
def test_a_clean_answer_in_one_step_is_what_receive_data_does(name: str, later: float) -> None:
    setup = SETUPS[name]
    taken = 0
    for read in [*READS, bytearray(encode_packet(OK_ANSWER))]:
        fast, general = setup(), setup()
        now = fast._now + later
        before = _snapshot(fast)
        packet = fast.receive_clean_answer(read, now)  # type: ignore[arg-type]
        events = general.receive_data(read, now)
        if packet is None:
            assert _snapshot(fast) == before, read
            continue
        taken += 1
        assert events == [AnswerReceived(packet, 0x30, final=True), ExchangeComplete()], read
        assert _snapshot(fast) == _snapshot(general), read
        out = fast.data_to_send()
        assert out == general.data_to_send()
        assert out.endswith(bytes((ACK,)))
        assert fast.state is State.IDLE
    # Only a single exchange waiting for its answer takes one in one step: every OK answer
    # arriving whole (a copy of the answer ACKed last unless it is taken for a resend).
    ok = [p for p in map(lone_frame, READS) if p is not None and p.lstrip(b"\xff")[:1] == b"0"]
    if name in ("single", "after a NAK", "after a corrupt answer", "a stop after the whole gap"):
        assert taken == len(ok) >= 8
    elif name.startswith("after an answer") or name == "a copy taken for a resend":
        assert taken in (len(ok), len(ok) - 1)
    else:
        assert taken == 0


def test_a_poll_answered_as_before_is_taken_in_one_step_unless_it_may_be_a_resend() -> None:
    answer = encode_packet(OK_ANSWER)
    link = HostLink()
    for now in (10.0, 10.01, 10.02):  # a status poll answered alike each time
        link.send_request(AA, Shape.SINGLE, now)
        assert link.receive_clean_answer(answer, now + 0.001) == OK_ANSWER
    # Our request went out right behind our ACK and the same answer comes after the
    # controller's own timeout: perhaps its resend (our ACK lost). The rules decide.
    link.send_request(AA, Shape.SINGLE, 10.021)
    assert link.receive_clean_answer(answer, 12.5) is None
    assert [type(e) for e in link.receive_data(answer, 12.5)] == [Ignored]


@given(st.binary(max_size=40).filter(lambda d: 2 not in d and 3 not in d))
def test_any_answer_in_one_step_is_what_receive_data_does(data: bytes) -> None:
    for setup in (SETUPS["single"], SETUPS["after an answer, at once"]):
        for read in (encode_packet(data), bytes((STX,)) + data + bytes((ETX, 0))):
            fast, general = setup(), setup()
            before = _snapshot(fast)
            packet = fast.receive_clean_answer(read, fast._now + 0.5)
            events = general.receive_data(read, general._now + 0.5)
            if packet is None:
                assert _snapshot(fast) == before
            else:
                assert events == [AnswerReceived(packet, 0x30, final=True), ExchangeComplete()]
                assert _snapshot(fast) == _snapshot(general)


def test_a_request_sent_again_goes_out_as_encode_packet_frames_it() -> None:
    """The link keeps the last request's frame for a request sent again (a poll): the bytes
    are encode_packet's, whatever came before, and a bad request is refused every time."""
    link = HostLink()
    now = 10.0
    for data in (AA, AA, b"\xffAC0", AA, b"", b"", b"\xffAC0", b"\xffAC0", AA):
        link.send_request(data, Shape.SINGLE, now)
        assert link.data_to_send() == encode_packet(data)
        link.abort(now)  # back to idle after the short gap
        link.data_to_send()
        now += 1.0
        link.handle_timeout(now)
        assert link.idle
        for bad in (b"\xffA\x02", b"\xffA\x03"):
            with pytest.raises(PacketTooLongError):
                link.send_request(bad, Shape.SINGLE, now)
            assert link.data_to_send() == b""


def test_a_poll_answered_alike_or_not_gives_each_read_its_own_packet() -> None:
    # receive_clean_answer keeps the last whole frame it found and its packet: the same read
    # again gives the same packet, any other read is framed anew (and a broken one refused).
    link = HostLink()
    other = b"0\xb5\x80\x81"
    broken = bytearray(encode_packet(other))
    broken[-1] ^= 0x01  # a bad LRC
    reads: list[tuple[bytes, bytes | None]] = [
        (encode_packet(OK_ANSWER), OK_ANSWER),
        (encode_packet(OK_ANSWER), OK_ANSWER),
        (encode_packet(other), other),
        (encode_packet(OK_ANSWER), OK_ANSWER),
        (bytes(broken), None),
        (encode_packet(other), other),
    ]
    now = 0.0
    for read, expected in reads:
        now += 0.01
        link.send_request(AA, Shape.SINGLE, now)
        link.data_to_send()
        packet = link.receive_clean_answer(read, now)
        assert packet == expected
        if packet is None:
            link.abort(now)
            now += 10.0
            link.handle_timeout(now)
            link.data_to_send()
            continue
        assert link.data_to_send() == bytes((ACK,))
        assert link.state is State.IDLE


# -- one accept step ----------------------------------------------------------------------------
def _spied(link: HostLink) -> list[tuple[bool, bytes | None]]:
    """Record each call of ``link``'s accept step (receive_clean_answer) the answer handler
    makes: whether it was given a framed Packet, and what it took."""
    calls: list[tuple[bool, bytes | None]] = []
    step = link.receive_clean_answer

    def spy(data: Any, now: float) -> bytes | None:
        taken = step(data, now)
        calls.append((isinstance(data, Packet), taken))
        return taken

    link.receive_clean_answer = spy  # type: ignore[method-assign]
    return calls


@pytest.mark.parametrize("name", list(SETUPS))
def test_the_usual_read_and_the_answer_handler_take_an_answer_in_the_same_step(
    name: str,
) -> None:
    """What the usual read takes in one step, the answer handler takes through that same step
    (its first branch, given the Packet the decoder framed), leaving the link as the read
    does: the step decides for both, for every setup and every answer."""
    setup = SETUPS[name]
    for read in READS:
        packet = lone_frame(read)
        if packet is None:
            continue
        fast, general = setup(), setup()
        now = fast._now + 0.05
        calls = _spied(general)
        taken = fast.receive_clean_answer(read, now)
        events = general.receive_data(read, now)
        del general.receive_clean_answer  # the spy
        if taken is not None:
            assert calls == [(True, packet)], read
            assert events == [AnswerReceived(packet, 0x30, final=True), ExchangeComplete()]
            assert _snapshot(fast) == _snapshot(general), read
        else:
            # Declined for the read (a frame begun before it, input held): the handler still
            # asks the same step, with the packet the decoder framed, and tells what it took.
            assert all(framed for framed, _ in calls), read
            for _, got in calls:
                if got is not None:
                    told = [AnswerReceived(got, 0x30, final=True), ExchangeComplete()]
                    assert events[-2:] == told


def test_a_clean_answer_behind_other_input_is_taken_by_the_same_step() -> None:
    """An OK answer the usual read cannot take at once (an ACK before it, the frame split
    over two reads) ends the exchange through the same accept step, in the handler."""
    answer = encode_packet(OK_ANSWER)
    for reads in ([bytes((ACK,)) + answer], [answer[:3], answer[3:]], [b"x" + answer]):
        link = _waiting(Shape.SINGLE)()
        calls = _spied(link)
        events = []
        for read in reads:
            assert link.receive_clean_answer(read, 10.1) is None
            events += link.receive_data(read, 10.1)
        assert calls[-1] == (True, OK_ANSWER)
        assert events[-2:] == [AnswerReceived(OK_ANSWER, 0x30, final=True), ExchangeComplete()]
        assert link.data_to_send() == bytes((ACK,)) and link.state is State.IDLE
