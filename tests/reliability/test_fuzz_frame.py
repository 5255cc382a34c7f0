"""Fuzzing the frame decoder: arbitrary bytes, arbitrary splits, mutated valid packets.

The decoder must never raise on bytes, give the same events however the bytes are split, let no
damaged packet through, and find good packets again right after any garbage.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reliability.samples import SAMPLES
from reliability.targets import Violation, check_frames, check_resync

from robostar.errors import FrameError
from robostar.protocol.frame import (
    ACK,
    ETX,
    NAK,
    RST,
    STX,
    CorruptPacket,
    FrameDecoder,
    Packet,
    encode_packet,
)

# Real packets: every sample's request and answers, framed.
VALID = tuple(
    sorted(
        {encode_packet(s.command.encode()) for s in SAMPLES}
        | {encode_packet(a) for s in SAMPLES for a in s.answer}
    )
)
valid_packet = st.sampled_from(VALID)
# Bytes that matter to the framing, weighted up so that the fuzzer meets them often.
line_byte = st.one_of(st.sampled_from((STX, ETX, ACK, NAK, RST, 0xFF, 0x30)), st.integers(0, 255))
garbage = st.lists(line_byte, max_size=300).map(bytes)
cuts = st.lists(st.integers(0, 10_000), max_size=12)


@st.composite
def mutated_stream(draw: st.DrawFn) -> bytes:
    """Valid packets and control bytes, then flips, drops, insertions and duplications."""
    parts = draw(st.lists(st.one_of(valid_packet, st.sampled_from((b"\x06", b"\x15"))), max_size=6))
    stream = bytearray(b"".join(parts))
    for _ in range(draw(st.integers(0, 6))):
        if not stream:
            stream.append(draw(line_byte))
            continue
        at = draw(st.integers(0, len(stream) - 1))
        op = draw(st.sampled_from(("flip", "drop", "insert", "dup")))
        if op == "flip":
            stream[at] ^= draw(st.integers(1, 255))
        elif op == "drop":
            del stream[at]
        elif op == "insert":
            stream.insert(at, draw(line_byte))
        else:
            stream.insert(at, stream[at])
    return bytes(stream)


@settings(max_examples=400, deadline=None)
@given(garbage, cuts)
def test_arbitrary_bytes_in_any_split(stream: bytes, where: list[int]) -> None:
    check_frames(stream, where)


@settings(max_examples=400, deadline=None)
@given(mutated_stream(), cuts)
def test_mutated_packets_in_any_split(stream: bytes, where: list[int]) -> None:
    check_frames(stream, where)


@settings(max_examples=400, deadline=None)
@given(st.one_of(garbage, mutated_stream()), valid_packet, valid_packet, cuts)
def test_resynced_on_the_next_good_packet(
    noise: bytes, first: bytes, second: bytes, where: list[int]
) -> None:
    check_resync(noise, first, second, where)


@settings(max_examples=200, deadline=None)
@given(st.lists(valid_packet, min_size=1, max_size=8), cuts)
def test_valid_packets_decode_exactly(packets: list[bytes], where: list[int]) -> None:
    events = check_frames(b"".join(packets), where)
    assert events == [Packet(p[1:-2]) for p in packets]


def test_one_flipped_bit_anywhere_is_never_a_good_packet() -> None:
    # Exhaustive over every sample packet, byte and bit: a single-bit error always shows, as
    # an LRC mismatch, a cut frame or noise, never as a different good packet.
    for packet in VALID:
        for at in range(len(packet)):
            for bit in range(8):
                damaged = bytearray(packet)
                damaged[at] ^= 1 << bit
                events = check_frames(bytes(damaged))
                wrong = [e for e in events if isinstance(e, Packet) and e.data != packet[1:-2]]
                assert not wrong, (packet, at, bit, events)


def test_a_bad_lrc_is_reported_not_swallowed() -> None:
    packet = bytearray(VALID[0])
    packet[-1] ^= 0x40
    events = FrameDecoder().feed(bytes(packet))
    assert [type(e) for e in events] == [CorruptPacket]


def test_the_resync_checker_reports_a_lost_packet() -> None:
    # Guard on the harness itself: a second packet with a spoiled LRC is "lost" and must be
    # reported, or the resync property above could never fail.
    spoiled = VALID[0][:-1] + bytes((VALID[0][-1] ^ 1,))
    with pytest.raises(Violation, match="second packet lost"):
        check_resync(b"", VALID[1], spoiled)


@pytest.mark.parametrize(
    ("stream", "cut"),
    [
        (b"\x02" + b"y" * 300 + b"\x03\x00", 260),
        (b"\x02" + b"\x00" * 372 + b"\x02\xffAA\x03\xff", 264),
    ],
    ids=["raw length", "TRUNCATED or TOO_LONG"],
)
def test_an_overlong_frame_is_reported_the_same_in_any_split(stream: bytes, cut: int) -> None:
    check_frames(stream, [cut])


@pytest.mark.parametrize("bad", ["\x02AA\x03", 2, None, [2, 3]])
def test_non_bytes_is_a_typed_error(bad: object) -> None:
    with pytest.raises(FrameError, match="takes bytes"):
        FrameDecoder().feed(bad)  # type: ignore[arg-type]
