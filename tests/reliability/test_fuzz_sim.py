"""Fuzzing the simulator's request handling: any request data, any byte stream.

After every input the simulator must still answer an AA exchange; it never raises and never
writes a damaged frame (see ``reliability/simfuzz.py``).
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reliability.samples import SAMPLES
from reliability.simfuzz import SimHarness

from robostar.protocol.frame import ETX, RST, STX, encode_packet
from robostar.sim import SimConfig, VirtualController

REQUESTS = tuple(s.command.encode() for s in SAMPLES)
no_framing = st.binary(max_size=80).map(lambda b: bytes(x for x in b if x not in (STX, ETX)))


@st.composite
def mutated_request(draw: st.DrawFn) -> bytes:
    out = bytearray(draw(st.sampled_from(REQUESTS)))
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(out)))
        op = draw(st.sampled_from(("flip", "cut", "add")))
        if op == "flip" and at < len(out):
            out[at] ^= draw(st.integers(1, 255))
        elif op == "cut":
            del out[at:]
        else:
            out[at:at] = draw(st.binary(min_size=1, max_size=3))
    return bytes(b for b in out if b not in (STX, ETX))


@pytest.fixture(scope="module")
def harness() -> SimHarness:
    return SimHarness()


@settings(max_examples=300, deadline=None)
@given(data=st.one_of(mutated_request(), no_framing, st.sampled_from(REQUESTS)))
def test_the_simulator_answers_after_any_request(harness: SimHarness, data: bytes) -> None:
    harness.feed(data)


framed_or_noise = st.one_of(st.sampled_from(REQUESTS).map(encode_packet), st.binary(max_size=12))


@settings(max_examples=150, deadline=None)
@given(parts=st.lists(framed_or_noise, max_size=6))
def test_the_simulator_takes_bytes_one_at_a_time(harness: SimHarness, parts: list[bytes]) -> None:
    # One byte per read: the multi-frame read is the known bug below.
    for byte in b"".join(parts):
        harness.give(bytes((byte,)))
    harness.settle()
    harness.probe()


@pytest.mark.parametrize(
    "chunk",
    [
        encode_packet(b"\xffAA") + bytes((RST,)),
        encode_packet(b"\xffAA") * 2,
    ],
    ids=["request+RST", "two requests"],
)
def test_a_request_and_more_in_one_read_does_not_crash_the_simulator(chunk: bytes) -> None:
    sim = VirtualController(SimConfig())
    sim.feed(chunk, 1.0)
    sim.output(1.0)
