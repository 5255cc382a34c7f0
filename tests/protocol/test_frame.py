"""Tests of packet framing: encode_packet's byte vectors and limits, FrameDecoder in any split."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from robostar.errors import FieldError, FrameError, PacketTooLongError, RobostarError
from robostar.protocol.frame import (
    ACK,
    ETX,
    MAX_PACKET,
    NAK,
    RST,
    STX,
    Control,
    CorruptPacket,
    CorruptReason,
    FrameDecoder,
    FrameEvent,
    Packet,
    encode_packet,
    lrc,
)
from robostar.protocol.frame import ControlKind as Kind

CONTROL_BYTES = (ACK, NAK, RST)
FRAMING_BYTES = (STX, ETX, *CONTROL_BYTES)

# Packet data may hold any byte but STX and ETX.
data_bytes = st.binary(max_size=MAX_PACKET - 3).filter(lambda d: STX not in d and ETX not in d)
# Line noise between packets: anything a decoder hunting for STX must throw away.
noise = st.binary(max_size=8).map(lambda b: bytes(x for x in b if x not in FRAMING_BYTES))


def feed_all(decoder: FrameDecoder, chunks: list[bytes]) -> list[FrameEvent]:
    events: list[FrameEvent] = []
    for chunk in chunks:
        events += decoder.feed(chunk)
    return events


def split_at(stream: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({min(c, len(stream)) for c in cuts})
    edges = [0, *points, len(stream)]
    return [stream[a:b] for a, b in itertools.pairwise(edges)]


def one_at_a_time(stream: bytes) -> list[FrameEvent]:
    decoder = FrameDecoder()
    return feed_all(decoder, [stream[i : i + 1] for i in range(len(stream))])


# -- encode_packet ------------------------------------------------------------------------------
def test_aa_request_vector_from_the_manual() -> None:
    assert encode_packet(b"\xffAA") == bytes.fromhex("02 FF 41 41 03 FF")


def test_answer_vectors() -> None:
    # A lone OK flag: LRC is the flag itself.
    assert encode_packet(b"0") == bytes.fromhex("02 30 03 30")
    # AA answer with three status bytes.
    assert encode_packet(b"0\xb5\x80\x80") == bytes.fromhex("02 30 B5 80 80 03 85")
    # BA request for channel 1 ('0').
    assert encode_packet(b"\xffBA0") == bytes.fromhex("02 FF 42 41 30 03 CC")


def test_zero_lrc_goes_out_as_etx() -> None:
    assert lrc(b"\xff\xff") == 0
    assert encode_packet(b"\xff\xff") == bytes.fromhex("02 FF FF 03 03")
    assert encode_packet(b"") == bytes.fromhex("02 03 03")
    assert encode_packet(b"00") == bytes.fromhex("02 30 30 03 03")


def test_lrc_is_the_xor_of_the_data_dummy_included() -> None:
    assert lrc(b"") == 0
    assert lrc(b"\xff") == 0xFF
    assert lrc(b"\xffAA") == 0xFF
    assert lrc(bytearray(b"\xffAB")) == 0xFF ^ 0x41 ^ 0x42


def test_the_longest_packet_is_250_bytes() -> None:
    packet = encode_packet(b"A" * (MAX_PACKET - 3))
    assert len(packet) == MAX_PACKET == 250


def test_a_longer_packet_is_refused() -> None:
    with pytest.raises(PacketTooLongError) as info:
        encode_packet(b"A" * (MAX_PACKET - 2))
    assert info.value.field == "packet"
    assert "251 bytes" in str(info.value)
    assert isinstance(info.value, FieldError)


@pytest.mark.parametrize("bad", [b"\xffA\x02A", b"\x03", b"0abc\x03", b"\x02"])
def test_stx_or_etx_in_data_is_refused(bad: bytes) -> None:
    with pytest.raises(FieldError) as info:
        encode_packet(bad)
    assert info.value.field == "packet"
    assert "STX" in str(info.value)


# -- FrameDecoder: whole packets ----------------------------------------------------------------
def test_a_packet_fed_whole() -> None:
    assert FrameDecoder().feed(bytes.fromhex("02 FF 41 41 03 FF")) == [Packet(b"\xffAA")]


def test_a_packet_fed_one_byte_at_a_time() -> None:
    decoder = FrameDecoder()
    stream = bytes.fromhex("02 30 B5 80 80 03 85")
    for byte in stream[:-1]:
        assert decoder.feed(bytes((byte,))) == []
        assert decoder.pending > 0 or byte == STX
    assert decoder.feed(stream[-1:]) == [Packet(b"0\xb5\x80\x80")]
    assert decoder.pending == 0


def test_many_packets_at_once() -> None:
    stream = encode_packet(b"\xffAA") + encode_packet(b"0\xb5\x80\x80") + encode_packet(b"4")
    assert FrameDecoder().feed(stream) == [
        Packet(b"\xffAA"),
        Packet(b"0\xb5\x80\x80"),
        Packet(b"4"),
    ]


def test_garbage_between_packets_is_dropped_and_counted() -> None:
    decoder = FrameDecoder()
    stream = b"xyz" + encode_packet(b"\xffAA") + b"\x00\xff" + encode_packet(b"0")
    assert decoder.feed(stream) == [Packet(b"\xffAA"), Packet(b"0")]
    assert decoder.discarded == 5


def test_bytearray_and_memoryview_are_accepted() -> None:
    decoder = FrameDecoder()
    packet = encode_packet(b"\xffAA")
    assert decoder.feed(bytearray(packet)) == [Packet(b"\xffAA")]
    assert decoder.feed(memoryview(packet)) == [Packet(b"\xffAA")]


def test_zero_lrc_accepted_as_etx_and_as_zero() -> None:
    assert FrameDecoder().feed(bytes.fromhex("02 30 30 03 03")) == [Packet(b"00")]
    assert FrameDecoder().feed(bytes.fromhex("02 30 30 03 00")) == [Packet(b"00")]


def test_lrc_of_three_is_not_mistaken_for_zero() -> None:
    # XOR 0x03 is sent as 0x03; a 0x00 LRC for it is a bad LRC.
    assert lrc(b"03") == 0x03
    assert FrameDecoder().feed(bytes.fromhex("02 30 33 03 03")) == [Packet(b"03")]
    events = FrameDecoder().feed(bytes.fromhex("02 30 33 03 00"))
    assert events == [CorruptPacket(CorruptReason.BAD_LRC, bytes.fromhex("02 30 33 03 00"))]


@pytest.mark.parametrize("value", [STX, ACK, NAK, RST, 0x00])
def test_the_byte_after_etx_is_the_lrc_whatever_its_value(value: int) -> None:
    # Find data whose XOR is ``value``: the LRC byte may look like a framing byte.
    data = bytes((0x30, 0x30 ^ value))
    assert lrc(data) == value
    stream = encode_packet(data) + encode_packet(b"4")
    assert FrameDecoder().feed(stream) == [Packet(data), Packet(b"4")]
    assert one_at_a_time(stream) == [Packet(data), Packet(b"4")]


# -- control bytes ------------------------------------------------------------------------------
def test_lone_control_bytes() -> None:
    decoder = FrameDecoder()
    assert decoder.feed(bytes((ACK,))) == [Control(Kind.ACK)]
    assert decoder.feed(bytes((NAK,))) == [Control(Kind.NAK)]
    assert decoder.feed(bytes((RST,))) == [Control(Kind.RST)]


def test_control_bytes_around_packets_keep_their_order() -> None:
    stream = bytes((ACK,)) + encode_packet(b"0") + bytes((NAK, RST)) + encode_packet(b"4")
    assert FrameDecoder().feed(stream) == [
        Control(Kind.ACK),
        Packet(b"0"),
        Control(Kind.NAK),
        Control(Kind.RST),
        Packet(b"4"),
    ]
    assert one_at_a_time(stream) == FrameDecoder().feed(stream)


# -- damage and resync --------------------------------------------------------------------------
def test_bad_lrc_is_reported_and_the_next_packet_decodes() -> None:
    decoder = FrameDecoder()
    bad = bytes.fromhex("02 FF 41 41 03 FE")
    events = decoder.feed(bad + encode_packet(b"\xffAB"))
    assert events == [CorruptPacket(CorruptReason.BAD_LRC, bad), Packet(b"\xffAB")]


def test_bad_lrc_across_feeds_does_not_wedge() -> None:
    decoder = FrameDecoder()
    assert decoder.feed(bytes.fromhex("02 30 31")) == []
    assert decoder.feed(bytes.fromhex("03")) == []
    events = decoder.feed(bytes.fromhex("99"))
    assert [type(e) for e in events] == [CorruptPacket]
    assert decoder.pending == 0
    assert decoder.feed(encode_packet(b"0")) == [Packet(b"0")]


def test_new_stx_mid_frame_truncates_the_old_frame() -> None:
    decoder = FrameDecoder()
    stream = bytes.fromhex("02 30 31 32") + encode_packet(b"0")
    # The new STX is also a frame start: the good packet after it is not lost.
    assert decoder.feed(stream) == [
        CorruptPacket(CorruptReason.TRUNCATED, bytes.fromhex("02 30 31 32")),
        Packet(b"0"),
    ]
    assert one_at_a_time(stream) == FrameDecoder().feed(stream)


def test_a_doubled_stx_is_an_empty_truncated_frame() -> None:
    stream = bytes((STX,)) + encode_packet(b"0")
    assert FrameDecoder().feed(stream) == [
        CorruptPacket(CorruptReason.TRUNCATED, bytes((STX,))),
        Packet(b"0"),
    ]


def test_control_bytes_inside_a_frame_are_data() -> None:
    # Between STX and ETX every byte is data: a 0x06 there is not an ACK.
    data = b"0" + bytes((ACK,))
    assert FrameDecoder().feed(encode_packet(data)) == [Packet(data)]


def test_an_overlong_frame_is_reported_once_then_the_next_packet_decodes() -> None:
    decoder = FrameDecoder()
    body = b"A" * 300
    stream = bytes((STX,)) + body + bytes((ETX, lrc(body))) + encode_packet(b"0")
    events = decoder.feed(stream)
    assert [type(e) for e in events] == [CorruptPacket, Packet]
    first = events[0]
    assert isinstance(first, CorruptPacket)
    assert first.reason is CorruptReason.TOO_LONG
    assert events[1] == Packet(b"0")


def test_an_overlong_frame_fed_bytewise_is_reported_as_soon_as_it_passes_250() -> None:
    decoder = FrameDecoder()
    events: list[FrameEvent] = []
    stream = bytes((STX,)) + b"A" * 400 + bytes((ETX, 0x41))
    reported_at = None
    for i in range(len(stream)):
        new = decoder.feed(stream[i : i + 1])
        if new and reported_at is None:
            reported_at = i
        events += new
    assert len(events) == 1
    assert isinstance(events[0], CorruptPacket)
    assert events[0].reason is CorruptReason.TOO_LONG
    # Index 248 is the 249th byte of the frame: 248 data bytes, so the packet is already 251.
    assert reported_at == MAX_PACKET - 2
    assert decoder.feed(encode_packet(b"\xffAA")) == [Packet(b"\xffAA")]


def test_overlong_frame_with_lrc_looking_like_stx_does_not_eat_the_next_frame() -> None:
    # The overlong frame's LRC byte is dropped whatever it is, even STX.
    stream = bytes((STX,)) + b"B" * 260 + bytes((ETX, STX)) + encode_packet(b"0")
    events = FrameDecoder().feed(stream)
    assert [getattr(e, "reason", None) for e in events] == [CorruptReason.TOO_LONG, None]
    assert events[-1] == Packet(b"0")


def test_new_stx_inside_an_overlong_frame_starts_a_new_frame() -> None:
    stream = bytes((STX,)) + b"C" * 260 + encode_packet(b"0")
    events = FrameDecoder().feed(stream)
    assert [type(e) for e in events] == [CorruptPacket, Packet]
    assert events[1] == Packet(b"0")


def test_a_frame_of_exactly_250_bytes_is_not_too_long() -> None:
    data = b"A" * (MAX_PACKET - 3)
    assert FrameDecoder().feed(encode_packet(data)) == [Packet(data)]
    assert one_at_a_time(encode_packet(data)) == [Packet(data)]


def test_reset_forgets_an_unfinished_frame() -> None:
    decoder = FrameDecoder()
    decoder.feed(bytes.fromhex("02 30 31"))
    assert decoder.pending == 2
    decoder.reset()
    assert decoder.pending == 0
    # ETX and a byte after reset are noise, not the end of the old frame.
    assert decoder.feed(bytes.fromhex("03 32")) == []
    assert decoder.feed(encode_packet(b"0")) == [Packet(b"0")]


@pytest.mark.parametrize("wrong", ["02 30 03 30", 0x02, [2, 48, 3, 48], None, 1.5])
def test_feeding_something_other_than_bytes_is_a_frame_error(wrong: object) -> None:
    decoder = FrameDecoder()
    with pytest.raises(FrameError, match="bytes"):
        decoder.feed(wrong)  # type: ignore[arg-type]
    assert decoder.feed(encode_packet(b"0")) == [Packet(b"0")]


# -- properties ---------------------------------------------------------------------------------
@given(data_bytes)
def test_every_packet_round_trips(data: bytes) -> None:
    packet = encode_packet(data)
    assert len(packet) == len(data) + 3 <= MAX_PACKET
    assert packet[0] == STX
    assert packet[-2] == ETX
    assert FrameDecoder().feed(packet) == [Packet(data)]


@given(st.binary(min_size=MAX_PACKET - 2, max_size=MAX_PACKET + 20))
def test_every_overlong_packet_is_refused(data: bytes) -> None:
    with pytest.raises(FieldError):
        encode_packet(data)


@given(st.lists(st.binary(max_size=40), max_size=12))
def test_arbitrary_bytes_never_raise_and_never_wedge(chunks: list[bytes]) -> None:
    decoder = FrameDecoder()
    try:
        events = feed_all(decoder, chunks)
    except RobostarError:  # pragma: no cover - a failure, reported below
        pytest.fail("bytes, however wrong, are not a misuse of the decoder")
    for event in events:
        assert isinstance(event, Packet | Control | CorruptPacket)
        if isinstance(event, Packet):
            assert len(event.data) <= MAX_PACKET - 3
            assert STX not in event.data
            assert ETX not in event.data
    # Whatever came before, the next packet decodes; an unfinished frame is cut short by its STX
    # -- unless that frame waited for its LRC byte: then the packet's STX is taken as that LRC
    # (an LRC may be 0x02), the frame is damaged, the packet lost with it (its sender resends
    # it), and the packet after it decodes. (Taking such an STX as the next frame's start
    # instead was tried: it lets an answer land on the wrong exchange when LRC bytes are lost.)
    packet = encode_packet(b"\xffAA")
    waited_for_lrc = _in_lrc(decoder)
    tail = decoder.feed(packet)
    if waited_for_lrc:
        assert [type(e) for e in tail] == [CorruptPacket]
        tail = decoder.feed(packet)
    assert tail[-1] == Packet(b"\xffAA")
    assert all(isinstance(e, CorruptPacket) for e in tail[:-1])
    assert len(tail) <= 2


def _in_lrc(decoder: FrameDecoder) -> bool:
    """The decoder has a frame's ETX and waits for its LRC byte."""
    return decoder._state.name == "LRC"


@given(st.binary(max_size=600), st.lists(st.integers(min_value=0, max_value=600), max_size=20))
def test_the_split_does_not_change_what_is_decoded(stream: bytes, cuts: list[int]) -> None:
    whole = FrameDecoder().feed(stream)
    split = feed_all(FrameDecoder(), split_at(stream, cuts))

    def shape(events: list[FrameEvent]) -> list[object]:
        # An overlong frame is reported as soon as it passes the limit, so how much of it the
        # report carries depends on the split; everything else must be identical.
        return [
            e.reason if isinstance(e, CorruptPacket) and e.reason is CorruptReason.TOO_LONG else e
            for e in events
        ]

    assert shape(split) == shape(whole)


@given(
    st.lists(st.tuples(noise, data_bytes), max_size=8),
    noise,
    st.lists(st.integers(min_value=0, max_value=2500), max_size=30),
)
def test_valid_packets_in_noise_in_any_split_decode_exactly(
    items: list[tuple[bytes, bytes]], trailing: bytes, cuts: list[int]
) -> None:
    stream = b"".join(gap + encode_packet(data) for gap, data in items) + trailing
    decoder = FrameDecoder()
    events = feed_all(decoder, split_at(stream, cuts))
    assert events == [Packet(data) for _, data in items]
    assert decoder.discarded == sum(len(gap) for gap, _ in items) + len(trailing)
    assert decoder.pending == 0


@given(
    st.lists(
        st.one_of(
            data_bytes.map(lambda d: ("packet", d)),
            st.sampled_from(CONTROL_BYTES).map(lambda b: ("control", bytes((b,)))),
        ),
        max_size=10,
    ),
    st.lists(st.integers(min_value=0, max_value=2500), max_size=30),
)
def test_packets_and_control_bytes_interleaved_keep_their_order(
    items: list[tuple[str, bytes]], cuts: list[int]
) -> None:
    stream = b"".join(encode_packet(raw) if kind == "packet" else raw for kind, raw in items)
    expected: list[FrameEvent] = [
        Packet(raw) if kind == "packet" else Control(Kind(raw[0])) for kind, raw in items
    ]
    assert feed_all(FrameDecoder(), split_at(stream, cuts)) == expected


@given(data_bytes.filter(bool), st.data())
def test_a_single_changed_data_or_lrc_byte_is_a_bad_lrc(data: bytes, draw: st.DataObject) -> None:
    packet = bytearray(encode_packet(data))
    etx_at = len(packet) - 2
    index = draw.draw(st.integers(1, len(packet) - 1).filter(lambda i: i != etx_at))
    packet[index] ^= draw.draw(st.integers(1, 255))
    # A new STX or ETX changes the framing (other tests); 0x00 for a zero LRC is accepted.
    assume(packet[index] not in (STX, ETX))
    assume(not (index == len(packet) - 1 and lrc(data) == 0 and packet[index] == 0))
    # A zero LRC is sent as 0x03: data whose XOR was 0 and is 3 after a change of 3 in one
    # byte ends in its own good LRC (the zero-LRC rule's blind spot, not the decoder's).
    assume(not (index < etx_at and lrc(bytes(packet[1:etx_at])) == packet[-1]))
    events = FrameDecoder().feed(bytes(packet) + encode_packet(b"0"))
    assert events == [CorruptPacket(CorruptReason.BAD_LRC, bytes(packet)), Packet(b"0")]


@given(st.binary(max_size=3 * MAX_PACKET))
def test_lrc_is_the_xor_of_every_byte_at_any_length(data: bytes) -> None:
    # Long packets take another route (folded as one integer): the same value either way.
    expected = 0
    for byte in data:
        expected ^= byte
    assert lrc(data) == expected
    assert lrc(bytearray(data)) == expected


@given(
    st.lists(st.sampled_from(CONTROL_BYTES), max_size=3),
    st.binary(max_size=MAX_PACKET + 10),
    st.none() | st.integers(min_value=0, max_value=255),
    st.binary(max_size=3),
    st.booleans(),
)
def test_a_read_decodes_as_its_bytes_fed_one_at_a_time(
    controls: list[int], body: bytes, check: int | None, tail: bytes, mid_frame: bool
) -> None:
    # Control bytes and then one whole frame in one read take a shorter path through the
    # decoder: it must give what the same bytes give one at a time (whatever the frame holds,
    # its LRC, what follows it, and whether a frame was already open), and leave the same state.
    lrc_byte = (lrc(body) or ETX) if check is None else check
    chunk = bytes(controls) + bytes((STX, *body, ETX, lrc_byte)) + tail
    opening = b"\x02ab" if mid_frame else b""
    whole, single = FrameDecoder(), FrameDecoder()
    whole.feed(opening)
    single.feed(opening)
    at_once = whole.feed(chunk)
    one_by_one = feed_all(single, [chunk[i : i + 1] for i in range(len(chunk))])

    def shape(events: list[FrameEvent]) -> list[object]:
        # As above: how much of an overlong frame its report carries depends on the split.
        return [
            e.reason if isinstance(e, CorruptPacket) and e.reason is CorruptReason.TOO_LONG else e
            for e in events
        ]

    assert shape(at_once) == shape(one_by_one)
    assert (whole.pending, whole.discarded) == (single.pending, single.discarded)
    follow = encode_packet(b"\xffAA")
    assert whole.feed(follow) == single.feed(follow)


def test_an_stx_where_an_lrc_was_due_is_taken_for_it() -> None:
    # The input hypothesis found: a frame that lost its LRC byte eats the next packet's STX.
    decoder = FrameDecoder()
    assert decoder.feed(b"\x02") == [] and decoder.feed(b"\x03") == []
    assert [type(e) for e in decoder.feed(encode_packet(b"\xffAA"))] == [CorruptPacket]
    assert decoder.feed(encode_packet(b"\xffAA")) == [Packet(b"\xffAA")]
