"""The threaded host's record of where a line stands in a packet (``_PacketTail``), which closes
a packet a departing client left half-sent: a read taken whole must leave it as the same bytes
taken one at a time do."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from robostar.protocol.frame import ACK, ETX, NAK, RST, STX
from robostar.sim.host import _PacketTail

# Bytes that matter to the tail (STX, ETX) and the control bytes, often, among any others.
line_bytes = st.binary(max_size=40) | st.lists(
    st.sampled_from((STX, ETX, ACK, NAK, RST, 0x30, 0x41, 0xFF)), max_size=40
).map(bytes)


def state(tail: _PacketTail) -> tuple[bool, bool, int, bytes]:
    return tail.in_packet, tail.in_lrc, tail.xor, tail.closing_bytes()


def feed_bytewise(tail: _PacketTail, data: bytes) -> None:
    """The rule, one byte at a time: after ETX the next byte is the LRC whatever it is; STX
    (re)starts a packet; inside one, every other byte counts in the XOR."""
    for byte in data:
        if tail.in_lrc:
            tail.in_lrc = False
        elif byte == STX:
            tail.in_packet = True
            tail.xor = 0
        elif tail.in_packet and byte == ETX:
            tail.in_packet = False
            tail.in_lrc = True
        elif tail.in_packet:
            tail.xor ^= byte


@given(st.lists(line_bytes, max_size=6))
def test_reads_taken_whole_leave_the_tail_as_the_bytewise_rule_does(reads: list[bytes]) -> None:
    whole, reference = _PacketTail(), _PacketTail()
    for data in reads:
        whole.feed(data)
        feed_bytewise(reference, data)
        assert state(whole) == state(reference)
