"""The one frame tracker (:class:`~robostar.protocol.frame.FrameTracker`) that the simulator's
fault injection and the threaded host's line tail share: it must stand where the decoder stands
(in a frame or between frames) after any bytes, take a read whole as it takes the same bytes one
at a time, and hold the LRC an encoded packet carries."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from robostar.protocol.frame import (
    ACK,
    ETX,
    NAK,
    RST,
    STX,
    FrameDecoder,
    FramePart,
    FrameTracker,
    encode_packet,
    lrc,
)

line_bytes = st.binary(max_size=300) | st.lists(
    st.sampled_from((STX, ETX, ACK, NAK, RST, 0x30, 0x41, 0xFF)), max_size=300
).map(bytes)


@given(st.lists(line_bytes, max_size=6))
def test_the_tracker_is_between_frames_exactly_when_the_decoder_is(reads: list[bytes]) -> None:
    tracker, decoder = FrameTracker(), FrameDecoder()
    for data in reads:
        tracker.feed(data)
        decoder.feed(data)
        assert decoder.between_frames == (not tracker.in_packet and not tracker.in_lrc)


@given(st.lists(line_bytes, max_size=6))
def test_a_read_taken_whole_is_the_same_bytes_stepped(reads: list[bytes]) -> None:
    whole, stepped = FrameTracker(), FrameTracker()
    for data in reads:
        whole.feed(data)
        for byte in data:
            stepped.step(byte)
        assert (whole.in_packet, whole.in_lrc, whole.xor) == (
            stepped.in_packet,
            stepped.in_lrc,
            stepped.xor,
        )
        assert whole.closing_bytes() == stepped.closing_bytes()


@given(st.binary(max_size=247).filter(lambda data: STX not in data and ETX not in data))
def test_each_byte_of_a_packet_gets_its_part_and_the_xor_its_lrc(data: bytes) -> None:
    tracker = FrameTracker()
    frame = encode_packet(data)
    parts = [tracker.step(byte) for byte in frame[:-1]]
    assert parts == [FramePart.START] + [FramePart.DATA] * (len(data) + 1)
    assert tracker.xor == lrc(data)
    assert tracker.step(frame[-1]) is FramePart.LRC
    assert tracker.step(ACK) is FramePart.OTHER


@given(st.binary(max_size=40))
def test_closing_bytes_end_a_begun_packet_as_a_corrupt_one(data: bytes) -> None:
    tracker, decoder = FrameTracker(), FrameDecoder()
    begun = bytes((STX,)) + data.replace(b"\x02", b"").replace(b"\x03", b"")
    tracker.feed(begun)
    decoder.feed(begun)
    events = decoder.feed(tracker.closing_bytes())
    assert decoder.between_frames
    assert [type(event).__name__ for event in events] == ["CorruptPacket"]


@given(st.lists(line_bytes, max_size=6))
def test_the_decoder_frames_with_a_tracker_that_stands_where_a_lone_one_does(
    reads: list[bytes],
) -> None:
    # The decoder runs on a FrameTracker of its own (one framing state machine): after any
    # reads it stands where a tracker fed the same bytes stands, with the same XOR inside a
    # packet (the LRC the decoder checks).
    tracker, decoder = FrameTracker(), FrameDecoder()
    for data in reads:
        tracker.feed(data)
        decoder.feed(data)
        framing = decoder._framing
        assert (framing.in_packet, framing.in_lrc) == (tracker.in_packet, tracker.in_lrc)
        if tracker.in_packet or tracker.in_lrc:
            assert framing.xor == tracker.xor
