"""Fuzzing every command's answer decoder, the request decoder and both link machines.

Answer decoders get their sample answers mutated (bytes flipped, cut, added; packets lost,
doubled, swapped) and arbitrary packets: only the library's typed errors may come out, and the
client turns every one of them into MalformedAnswerError. The request decoder (the simulator's
first step) and the link machines get arbitrary and mutated bytes.
"""

from __future__ import annotations

import contextlib
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reliability.samples import SAMPLES, Sample
from reliability.targets import (
    check_answer,
    check_controller_link,
    check_host_link,
    check_request,
)

from robostar.client.driver import decode
from robostar.commands import decode_request
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.frame import ACK, ETX, NAK, RST, STX, encode_packet

sample = st.sampled_from(SAMPLES)
any_packet = st.binary(max_size=120)


def _ids(s: Sample) -> str:
    return f"{s.command.CODE}-{type(s.command).__name__}"


@st.composite
def mutated_bytes(draw: st.DrawFn, data: bytes) -> bytes:
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(("flip", "cut", "add", "space", "digit")))
        at = draw(st.integers(0, len(out)))
        if op == "flip" and at < len(out):
            out[at] ^= draw(st.integers(1, 255))
        elif op == "cut":
            del out[at:]
        elif op == "add":
            out[at:at] = draw(st.binary(min_size=1, max_size=4))
        elif op == "space" and at < len(out):
            out[at] = 0x20
        elif op == "digit" and at < len(out):
            out[at] = draw(st.integers(0x30, 0x39))
    return bytes(out)


@st.composite
def mutated_answer(draw: st.DrawFn, packets: list[bytes]) -> list[bytes]:
    out = list(packets)
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(("bytes", "lose", "double", "swap", "foreign")))
        at = draw(st.integers(0, max(len(out) - 1, 0)))
        if op == "bytes" and out:
            out[at] = draw(mutated_bytes(out[at]))
        elif op == "lose" and out:
            del out[at]
        elif op == "double" and out:
            out.insert(at, out[at])
        elif op == "swap" and len(out) > 1:
            j = draw(st.integers(0, len(out) - 1))
            out[at], out[j] = out[j], out[at]
        elif op == "foreign":
            other = draw(sample)
            out.insert(at, draw(st.sampled_from(other.answer)))
    return out


# -- answers -----------------------------------------------------------------------------------
@pytest.mark.parametrize("case", SAMPLES, ids=_ids)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_every_answer_decoder_takes_mutated_answers(case: Sample, data: st.DataObject) -> None:
    packets = data.draw(mutated_answer(case.answer))
    check_answer(case.command, packets)
    # The client's decoding: every field fault becomes MalformedAnswerError, nothing else.
    with contextlib.suppress(MalformedAnswerError):
        decode(case.command, tuple(packets))


@settings(max_examples=300, deadline=None)
@given(sample, st.lists(any_packet, max_size=5))
def test_every_answer_decoder_takes_arbitrary_packets(case: Sample, packets: list[bytes]) -> None:
    check_answer(case.command, packets)


@pytest.mark.parametrize("case", SAMPLES, ids=_ids)
def test_the_sample_answers_round_trip(case: Sample) -> None:
    # The mutations start from valid answers, or the fuzzing above would prove little.
    assert case.command.decode_answer(case.answer) == case.result


def _fa_samples() -> list[Sample]:
    return [s for s in SAMPLES if s.command.CODE == "FA"]


@pytest.mark.parametrize("case", _fa_samples(), ids=_ids)
def test_a_download_with_a_packet_doubled_is_never_a_wrong_file(case: Sample) -> None:
    packets = case.answer
    for at in range(len(packets) - 1):
        doubled = [*packets[: at + 1], packets[at], *packets[at + 1 :]]
        with pytest.raises(MalformedAnswerError):
            decode(case.command, tuple(doubled))


@pytest.mark.parametrize("case", _fa_samples(), ids=_ids)
def test_a_download_with_a_packet_lost_is_never_a_wrong_file(case: Sample) -> None:
    # FA's first packet is a count on some controllers and the capacity on others (issue #19):
    # losing a line or point in the middle cannot be seen by the decoder (the link's ACKs
    # prevent that loss). Losing the announcement, or the END, always is.
    packets = case.answer
    for at in range(len(packets) - 1):
        lost = [*packets[:at], *packets[at + 1 :]]
        if 0 < at < len(packets) - 1:
            continue
        with pytest.raises(MalformedAnswerError):
            decode(case.command, tuple(lost))


# -- requests (the simulator's decoding) -------------------------------------------------------
REQUESTS = tuple(s.command.encode() for s in SAMPLES)
HEADS = sorted({r[:3] for r in REQUESTS})


@settings(max_examples=500, deadline=None)
@given(st.one_of(st.binary(max_size=80), st.sampled_from(REQUESTS).flatmap(mutated_bytes)))
def test_the_request_decoder_takes_any_data(data: bytes) -> None:
    check_request(data)


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(HEADS),
    st.binary(max_size=70),
)
def test_the_request_decoder_takes_any_params(head: bytes, params: bytes) -> None:
    check_request(head + params)


def test_a_coordinate_with_four_decimals_is_refused() -> None:
    with pytest.raises(FieldError):
        decode_request(b"\xffBD000     1.00     0.000     0.000     0.0004")


def test_a_coordinate_too_wide_for_3_decimals_is_refused() -> None:
    # Found by atheris: "2000004601" has no decimal point and fits 10 bytes as digits, but no
    # sender can write it with the 3 decimals the field carries, so no host could have sent it.
    with pytest.raises(FieldError, match="does not fit 10 bytes"):
        decode_request(b"\xffGW000400000200000460101")
    assert check_request(b"\xffGW000400000200000460101") == "FieldError"


@pytest.mark.parametrize("request_data", REQUESTS)
def test_every_sample_request_decodes(request_data: bytes) -> None:
    assert check_request(request_data) != "FieldError"


# -- link machines -----------------------------------------------------------------------------
line_byte = st.one_of(st.sampled_from((STX, ETX, ACK, NAK, RST, 0xFF, 0x30, 0x34)), st.integers())
chunk = st.one_of(
    st.lists(line_byte.map(lambda b: b & 0xFF), max_size=20).map(bytes),
    sample.flatmap(lambda s: st.sampled_from(s.answer)).map(encode_packet),
    sample.map(lambda s: encode_packet(s.command.encode())),
    st.sampled_from((b"\x06", b"\x15", b"\x12")),
)


@settings(max_examples=300, deadline=None)
@given(sample, st.lists(chunk, max_size=12))
def test_the_host_link_takes_any_bytes(case: Sample, chunks: list[bytes]) -> None:
    check_host_link(case.command.encode(), case.command, chunks)


@settings(max_examples=300, deadline=None)
@given(sample, st.lists(chunk, max_size=12))
def test_the_controller_link_takes_any_bytes(case: Sample, chunks: list[bytes]) -> None:
    answers: Any = case.answer[:1]
    check_controller_link(chunks, answers)
