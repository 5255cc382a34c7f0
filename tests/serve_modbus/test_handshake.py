"""The handshake's command block, register by register: every command code becomes the N1
command(s) the table in docs/modbus.md names, with its parameters checked before anything is
sent; the sequencer runs each new number once and never the first one after a start."""

from __future__ import annotations

import struct

import pytest

from robostar.commands.control import (
    EmergencyStop,
    ResetAlarms,
    ResetJob,
    SetSpeed,
    StartJob,
    StopHoming,
    StopJob,
)
from robostar.commands.io import SetOutput
from robostar.commands.job import Servo
from robostar.commands.motion import Home, JogStop
from robostar.commands.variables import WriteGlobalFloat, WriteGlobalInt
from robostar.errors import UsageError
from robostar.serve.faces.modbus.handshake import CODES, Sequencer, Take, parse_request


def _block(code: int, *params: int, sequence: int = 1) -> list[int]:
    return [code, *params, *[0] * (8 - len(params)), sequence]


def _words(fmt: str, value: float) -> tuple[int, int]:
    high, low = struct.unpack(">HH", struct.pack(fmt, value))
    return int(high), int(low)


@pytest.mark.parametrize(
    ("block", "expected"),
    [
        (_block(2, 1), (StartJob(1),)),
        (_block(4, 2), (StopJob(2),)),
        (_block(5, 1, 1), (Servo(1, True),)),
        (_block(5, 3, 0), (Servo(3, False),)),
        (_block(6), (ResetAlarms(),)),
        (_block(7, 1, 1000), (SetSpeed(1, 1000),)),
        (_block(8, 4, 15, 1), (SetOutput(4, 15, True),)),
        (_block(9, 499, *_words(">i", -2)), (WriteGlobalInt(499, -2),)),
        (_block(10, 0, *_words(">f", -1.5)), (WriteGlobalFloat(0, -1.5),)),
        (_block(11), (EmergencyStop(),)),
        (_block(12, 2), (JogStop(2),)),
        (_block(13, 1), (ResetJob(1),)),
        (_block(14, 2), (Home(2),)),
        (_block(15, 1), (StopHoming(1),)),
    ],
)
def test_each_code_becomes_its_command(block: list[int], expected: tuple[object, ...]) -> None:
    request = parse_request(block)
    assert request.commands == expected
    assert request.name == CODES[block[0]][0]
    assert request.is_stop == (block[0] in (4, 11, 12, 15))


@pytest.mark.parametrize("value", [0.1, 2.675, -1234.567, 99999.99, 0.001, -0.3, 100.0])
def test_a_plcs_real_is_the_decimal_it_meant(value: float) -> None:
    """A float32 holds 0.1 as 0.10000000149...: GW must get 0.1, not a refusal as too fine."""
    (command,) = parse_request(_block(10, 7, *_words(">f", value))).commands
    assert command == WriteGlobalFloat(7, value)
    command.encode()


def test_a_real_finer_than_the_field_is_still_refused() -> None:
    with pytest.raises(UsageError, match="finer"):
        parse_request(_block(10, 0, *_words(">f", 0.1234)))


def test_the_job_codes_name_a_job_number_to_look_up() -> None:
    run = parse_request(_block(3, 2, 17))
    assert (run.channel, run.job, run.start, run.commands) == (2, 17, True, ())
    select = parse_request(_block(1, 1, 0))
    assert (select.channel, select.job, select.start) == (1, 0, False)


@pytest.mark.parametrize(
    "block",
    [
        _block(99),  # no such code
        _block(2, 0),  # channel 0
        _block(2, 4),  # channel 4
        _block(3, 1, 201),  # JOB numbers are 0-200
        _block(5, 1, 2),  # on is 0 or 1
        _block(7, 1, 1001),  # speed 0-1000
        _block(8, 5, 0, 1),  # port 0-4
        _block(8, 0, 16, 1),  # contact 0-15
        _block(9, 500, 0, 0),  # index 0-499
        _block(10, 0, *_words(">f", float("nan"))),
    ],
)
def test_bad_parameters_are_refused_before_anything_is_sent(block: list[int]) -> None:
    with pytest.raises(UsageError):
        parse_request(block)


def test_the_sequencer_runs_each_new_number_once_but_never_the_first() -> None:
    sequencer = Sequencer()
    assert sequencer.take(0) is Take.NOTHING
    assert sequencer.take(5) is Take.BASELINE
    assert sequencer.take(5) is Take.NOTHING
    assert sequencer.take(6) is Take.RUN
    assert sequencer.take(6) is Take.NOTHING
    assert sequencer.take(0) is Take.NOTHING
    assert sequencer.take(5) is Take.RUN  # any other number is new, in any order
