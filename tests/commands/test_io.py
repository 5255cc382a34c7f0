"""I/O commands GA-GD: byte vectors from the manual, round trips, range checks."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.commands import Command, Shape, decode_request
from robostar.commands.io import ReadInputs, ReadIOBoards, ReadOutputs, SetOutput
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.frame import encode_packet
from robostar.types import IOState

from .checks import assert_class_attributes, assert_decodes_to, assert_round_trip

ports = st.integers(0, 4)
contact_states = st.lists(st.booleans(), min_size=16, max_size=16).map(tuple)


def field_error(exc: pytest.ExceptionInfo[FieldError], command: str, field: str, flag: int) -> None:
    assert (exc.value.command, exc.value.field, exc.value.flag) == (command, field, flag)
    assert field in str(exc.value)


REQUESTS: list[tuple[Command[Any], bytes]] = [
    # Port as two ASCII digits: the manual's "01".
    (ReadInputs(1), b"\xffGA" + b"01"),
    (ReadInputs(0), b"\xffGA" + b"00"),
    (ReadOutputs(1), b"\xffGB" + b"01"),
    (ReadOutputs(4), b"\xffGB" + b"04"),
    # The manual's GC example: port 1, contact 12, on.
    (SetOutput(1, 12, True), b"\xff" + b"G" + b"C" + b"0" + b"1" + b"1" + b"2" + b"1"),
    (SetOutput(4, 0, False), b"\xffGC" + b"04" + b"00" + b"0"),
    (ReadIOBoards(), b"\xffGD"),
]


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_encodes_to_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert command.encode() == data


@pytest.mark.parametrize(("command", "data"), REQUESTS)
def test_request_decodes_from_the_manuals_bytes(command: Command[Any], data: bytes) -> None:
    assert_decodes_to(command, data)


def test_framed_packets_carry_the_lrc() -> None:
    # LRC of the manual's GC example: FF^'G'^'C'^'0'^'1'^'1'^'2'^'1' = 0xC8.
    assert encode_packet(SetOutput(1, 12, True).encode()) == b"\x02\xffGC01121\x03\xc8"
    assert encode_packet(ReadInputs(1).encode()) == b"\x02\xffGA01\x03\xf8"
    state = IOState(1, (True, False, False, True) + (False,) * 11 + (True,))
    assert (
        encode_packet(ReadInputs(1).encode_answer(state)[0]) == b"\x02016\x39\x30\x30\x31\x03\x3f"
    )


def test_receivers_accept_a_space_padded_port() -> None:
    assert decode_request(b"\xffGA 1") == ReadInputs(1)
    assert decode_request(b"\xffGC" + b" 1" + b"12" + b"1") == SetOutput(1, 12, True)
    assert decode_request(b"\xffGC" + b"01" + b" 7" + b"0") == SetOutput(1, 7, False)


@pytest.mark.parametrize(
    ("cls", "changes_state"),
    [(ReadInputs, False), (ReadOutputs, False), (SetOutput, True), (ReadIOBoards, False)],
)
def test_class_attributes(cls: type[Command[Any]], changes_state: bool) -> None:
    assert cls.SHAPE is Shape.SINGLE
    assert_class_attributes(cls, changes_state=changes_state, dummy=False)


# -- answers ---------------------------------------------------------------------------------


@pytest.mark.parametrize("cls", [ReadInputs, ReadOutputs])
def test_port_answer_both_ways(cls: type[ReadInputs]) -> None:
    # "16" contacts, then 0x30|nibble per 4 contacts; IN0 is the first byte's 0x8 bit.
    # Contacts 0, 3, 6 and 15 on: 0x39, 0x32, 0x30, 0x31.
    on = {0, 3, 6, 15}
    state = IOState(2, tuple(i in on for i in range(16)))
    answer = [b"0" + b"16" + b"\x39\x32\x30\x31"]
    assert cls(2).decode_answer(answer) == state
    assert cls(2).encode_answer(state) == answer
    assert state.on == (0, 3, 6, 15)
    assert cls(0).decode_answer([b"0" + b"16" + b"\x3f\x3f\x3f\x3f"]) == IOState(0, (True,) * 16)


@pytest.mark.parametrize("cls", [ReadInputs, ReadOutputs])
def test_port_answer_is_checked(cls: type[ReadInputs]) -> None:
    with pytest.raises(MalformedAnswerError):
        cls(1).decode_answer([b"0" + b"08" + b"\x30\x30\x30\x30"])
    with pytest.raises(FieldError):
        cls(1).decode_answer([b"0" + b"16" + b"\x30\x30\x30\x40"])
    with pytest.raises(FieldError):
        cls(1).decode_answer([b"0" + b"16" + b"\x30\x30\x30"])
    with pytest.raises(FieldError):
        cls(1).decode_answer([b"0" + b"16" + b"\x30\x30\x30\x30\x30"])
    with pytest.raises(FieldError) as exc:
        cls(1).encode_answer(IOState(1, (True,) * 15))
    assert exc.value.field == "contacts"
    with pytest.raises(FieldError) as exc:
        cls(1).encode_answer(IOState(2, (True,) * 16))
    assert exc.value.field == "port"


@pytest.mark.parametrize("cls", [ReadInputs, ReadOutputs])
@given(port=ports, contacts=contact_states)
def test_port_answer_round_trip(
    cls: type[ReadInputs], port: int, contacts: tuple[bool, ...]
) -> None:
    command = cls(port)
    state = IOState(port, contacts)
    assert command.decode_answer(command.encode_answer(state)) == state


def test_gc_answer_is_a_bare_flag() -> None:
    assert SetOutput(1, 12, True).encode_answer(None) == [b"0"]
    SetOutput(1, 12, True).decode_answer([b"0"])
    with pytest.raises(FieldError):
        SetOutput(1, 12, True).decode_answer([b"0" + b"1"])


def test_gd_answer_both_ways() -> None:
    # The manual's example: "01" input boards, "01" output boards.
    assert ReadIOBoards().decode_answer([b"0" + b"01" + b"01"]) == (1, 1)
    assert ReadIOBoards().encode_answer((1, 1)) == [b"0" + b"01" + b"01"]
    assert ReadIOBoards().encode_answer((0, 2)) == [b"0" + b"00" + b"02"]
    assert ReadIOBoards().decode_answer([b"0" + b" 2" + b" 0"]) == (2, 0)


@given(st.integers(0, 2), st.integers(0, 2))
def test_gd_answer_round_trip(inputs: int, outputs: int) -> None:
    answer = ReadIOBoards().encode_answer((inputs, outputs))
    assert ReadIOBoards().decode_answer(answer) == (inputs, outputs)


def test_gd_board_counts_are_0_to_2() -> None:
    with pytest.raises(FieldError) as exc:
        ReadIOBoards().decode_answer([b"0" + b"03" + b"01"])
    assert exc.value.field == "input boards"
    with pytest.raises(FieldError) as exc:
        ReadIOBoards().encode_answer((1, 3))
    assert exc.value.field == "output boards"


# -- limits ----------------------------------------------------------------------------------


@pytest.mark.parametrize("cls", [ReadInputs, ReadOutputs])
def test_port_range(cls: type[ReadInputs]) -> None:
    for bad in (-1, 5):
        with pytest.raises(FieldError) as exc:
            cls(bad).encode()
        field_error(exc, cls.CODE, "port", 0x31)
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xff" + cls.CODE.encode() + b"05")
    field_error(exc, cls.CODE, "port", 0x31)


@pytest.mark.parametrize("raw", [b"0\x01", b"0\x00", b"1"])
def test_a_port_sent_as_a_raw_byte_is_refused(raw: bytes) -> None:
    # Seen in the field: '0' then a raw byte 0x00-0x04. A controller answers 0x31.
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffGA" + raw)
    field_error(exc, "GA", "port", 0x31)


def test_gc_limits() -> None:
    for command, field in [
        (SetOutput(5, 1, True), "port"),
        (SetOutput(1, 16, True), "contact"),
        (SetOutput(1, -1, True), "contact"),
        (SetOutput(1, 1, 1), "on"),  # type: ignore[arg-type]
    ]:
        with pytest.raises(FieldError) as exc:
            command.encode()
        field_error(exc, "GC", field, 0x31)
    for data, field in [
        (b"\xffGC01162", "contact"),
        (b"\xffGC01122", "on"),
        (b"\xffGC0116", "contact"),
        (b"\xffGC01121x", "packet"),
    ]:
        with pytest.raises(FieldError) as exc:
            decode_request(data)
        field_error(exc, "GC", field, 0x31)


def test_gd_request_has_no_fields() -> None:
    with pytest.raises(FieldError) as exc:
        decode_request(b"\xffGD0")
    assert exc.value.field == "packet"


any_io_command = st.one_of(
    st.builds(ReadInputs, ports),
    st.builds(ReadOutputs, ports),
    st.builds(SetOutput, ports, st.integers(0, 15), st.booleans()),
    st.just(ReadIOBoards()),
)


@given(any_io_command)
def test_request_round_trip(command: Command[Any]) -> None:
    assert_round_trip(command)
