"""The client against a damaged line: a FaultInjector between it and the simulator.

Whatever the fault - a byte corrupted, dropped or doubled, an RST, a spoilt LRC, a NAK storm, a
delay, a cut line - a call either succeeds or raises a typed line/protocol error; a state
change is never carried out twice (``controller.executions``); no call outlives its timeouts
(pytest-timeout, and measured); and the next call works again.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from robostar.client import Client
from robostar.errors import (
    ControllerError,
    LineError,
    NakLimitError,
    OutcomeUnknownError,
    PortError,
    ProtocolError,
    ReplyTimeoutError,
    RobostarError,
    UploadIncompleteError,
)
from robostar.sim import VirtualController
from robostar.sim.faults import FaultInjector
from robostar.sim.listeners import SimServer
from robostar.transport import PeerTransport

from .conftest import sim_config

pytestmark = pytest.mark.timeout(30)

TIMEOUT = 0.15
# The controller resends an unacknowledged answer after this long; above the host's timeout,
# and above the host's 0.25 s resend window so a resend is told from new data.
ACK_TIMEOUT = 0.3
# The worst a call may take: every try of a read timing out, the RST, and slack for the machine.
BOUND = 4 * TIMEOUT + 1.5


class Line:
    def __init__(self, seed: int) -> None:
        self.controller = VirtualController(sim_config(ack_timeout=ACK_TIMEOUT))
        self.faults = FaultInjector(self.controller, seed=seed)
        self.client = Client(
            PeerTransport(self.faults),
            timeout=TIMEOUT,
            poll_interval=0.005,
            controller_timeout=ACK_TIMEOUT,
        )

    def timed(self, call: Callable[[], Any]) -> tuple[Any, float]:
        started = time.monotonic()
        try:
            result = call()
        except RobostarError as exc:
            result = exc
        return result, time.monotonic() - started

    def recovers(self) -> None:
        """The line works again at once when the faults are gone."""
        self.faults.clear()
        assert self.client.status()[0].ready


@pytest.fixture
def line(request: pytest.FixtureRequest) -> Iterator[Line]:
    bench = Line(seed=hash(request.node.name) & 0xFFFF)
    try:
        yield bench
    finally:
        bench.client.close()


def typed(result: object) -> bool:
    return not isinstance(result, BaseException) or isinstance(
        result, LineError | ProtocolError | ControllerError
    )


BYTE_FAULTS = ["corrupt", "drop", "dup", "rst", "corrupt-lrc"]
POSITIONS = [0, 1, 3, 5, 7]


@pytest.mark.parametrize("direction", ["to_controller", "to_host"])
@pytest.mark.parametrize("kind", BYTE_FAULTS)
@pytest.mark.parametrize("at", POSITIONS)
def test_a_read_recovers_or_fails_typed(line: Line, kind: str, direction: str, at: int) -> None:
    line.faults.schedule(kind, direction, at_byte=at)
    result, took = line.timed(line.client.status)
    assert typed(result), result
    assert took < BOUND
    if not isinstance(result, BaseException):
        assert result[0].ready
    line.recovers()


@pytest.mark.parametrize("direction", ["to_controller", "to_host"])
@pytest.mark.parametrize("kind", BYTE_FAULTS)
@pytest.mark.parametrize("at", POSITIONS)
def test_a_write_is_never_done_twice(line: Line, kind: str, direction: str, at: int) -> None:
    line.faults.schedule(kind, direction, at_byte=at)
    result, took = line.timed(lambda: line.client.write_global_int(3, 1234))
    assert typed(result), result
    assert took < BOUND
    done = line.controller.executions["GW"]
    assert done <= 1
    if result is None:
        assert done == 1
    line.recovers()
    if result is None:
        assert line.client.read_global_int(3) == 1234
    assert line.controller.executions["GW"] == done


@pytest.mark.parametrize("at", [0, 5, 12, 30, 60])
@pytest.mark.parametrize("kind", ["drop", "corrupt"])
def test_a_multi_packet_read_recovers_or_fails_typed(line: Line, kind: str, at: int) -> None:
    line.faults.schedule(kind, "to_host", at_byte=at)
    result, took = line.timed(lambda: line.client.download_job(1, "DEMO.JOB"))
    assert typed(result), result
    assert took < BOUND
    if not isinstance(result, BaseException):
        assert result.lines[0] == "MAIN" and result.lines[-1] == "EOP"
    line.recovers()


def test_a_lost_answer_to_a_read_is_retried(line: Line) -> None:
    line.faults.schedule("drop", "to_host", at_byte=0, count=7)
    assert line.client.status()[0].ready
    assert line.controller.requests == 2


def test_a_lost_answer_to_a_write_is_not_resent(line: Line) -> None:
    line.faults.schedule("drop", "to_host", at_byte=0, count=5)
    with pytest.raises(OutcomeUnknownError) as caught:
        line.client.set_speed(1, 700)
    assert caught.value.command == "CB"
    assert line.controller.executions["CB"] == 1
    line.recovers()
    assert line.client.speed(1) == 700


def test_a_nak_storm_ends_a_read_in_nak_limit(line: Line) -> None:
    line.faults.schedule("nak", count=4)
    with pytest.raises(NakLimitError):
        line.client.status()
    line.recovers()


def test_a_nak_storm_on_a_state_change_is_resent_once_then_unknown(line: Line) -> None:
    # After one resend a NAK may be a doubled copy of the first (the resend then reached the
    # controller): no third copy; with no answer the outcome is unknown, never a double.
    line.faults.schedule("nak", count=4)
    with pytest.raises(OutcomeUnknownError, match="not resent"):
        line.client.set_speed(1, 700)
    assert line.controller.executions["CB"] == 0
    line.recovers()


def test_a_write_whose_answer_stays_corrupt_has_an_unknown_outcome(line: Line) -> None:
    # The host NAKs three damaged answers and gives up at the fourth: the controller did act.
    line.faults.schedule("corrupt-lrc", "to_host", count=4)
    with pytest.raises(OutcomeUnknownError):
        line.client.set_speed(1, 700)
    assert line.controller.executions["CB"] == 1
    line.recovers()
    assert line.client.speed(1) == 700


def test_a_read_whose_answer_stays_corrupt_ends_in_nak_limit(line: Line) -> None:
    line.faults.schedule("corrupt-lrc", "to_host", count=4)
    with pytest.raises(NakLimitError):
        line.client.status()
    line.recovers()


def test_three_naks_are_survived_by_a_read(line: Line) -> None:
    line.faults.schedule("nak", count=3)
    assert line.client.speed(1) == 300


def test_one_nak_is_survived_by_a_state_change(line: Line) -> None:
    line.faults.schedule("nak", count=1)
    line.client.set_speed(1, 700)
    assert line.controller.executions["CB"] == 1


def test_a_slow_answer_times_out_and_does_not_confuse_the_next_call(line: Line) -> None:
    # Held longer than both tries take (each: the timeout, then the quiet gap after RST).
    hold = 1.0
    line.faults.schedule("delay", "to_host", at_byte=0, seconds=hold)
    with pytest.raises(ReplyTimeoutError):
        line.client.position(1)
    time.sleep(hold)  # the late answers land while the line is idle
    line.recovers()
    assert line.client.position(1, "angle").kind.name == "ANGLE"


def test_a_short_delay_is_waited_out(line: Line) -> None:
    line.faults.schedule("delay", "to_host", at_byte=2, seconds=TIMEOUT / 3)
    assert line.client.speed(1) == 300


@pytest.mark.parametrize("kind", ["corrupt", "drop", "dup"])
def test_line_noise_on_every_call(line: Line, kind: str) -> None:
    line.faults.add_rate(kind, 0.01, "both")
    for _ in range(20):
        result, took = line.timed(line.client.status)
        assert typed(result), result
        assert took < BOUND
    line.recovers()


# -- uploads ----------------------------------------------------------------------------------
LINES = ("MAIN", "JMOV P1", "DELAY 50", "EOP")
# The controller's bytes during FB: a 5-byte reply to the request and to each line, then the
# lone ACK that closes the upload. The uploads name their JOB number, so that FB is the first
# exchange (without it, FD looks the number up first).
FINAL_ACK = 5 * (len(LINES) + 1)


def test_an_upload_whose_final_ack_is_lost_is_verified_by_reading_back(line: Line) -> None:
    line.faults.schedule("drop", "to_host", at_byte=FINAL_ACK)
    line.client.upload_job(1, "NEW.JOB", LINES, number=2)
    assert line.faults.total() == 1
    assert line.controller.executions["FB"] == 1
    # FB; the fence (AA) before the next request after an exchange given up (its error
    # reply could still come); then FA to read the file back
    assert line.controller.requests == 3
    assert line.client.download_job(1, "NEW.JOB").lines == LINES


@pytest.mark.parametrize("at", [0, 5, 7, 12])
def test_an_upload_cut_short_is_reported_incomplete(line: Line, at: int) -> None:
    line.faults.schedule("drop", "to_host", at_byte=at, count=5)
    with pytest.raises(UploadIncompleteError):
        line.client.upload_job(1, "NEW.JOB", LINES, number=2)
    assert line.controller.executions["FB"] == 0
    line.recovers()


@pytest.mark.parametrize("kind", ["corrupt", "dup"])
@pytest.mark.parametrize("at", [0, 4, 9, 16])
def test_an_upload_survives_damaged_bytes_or_says_so(line: Line, kind: str, at: int) -> None:
    line.faults.schedule(kind, "to_controller", at_byte=at)
    result, took = line.timed(lambda: line.client.upload_job(1, "NEW.JOB", LINES, number=2))
    assert took < BOUND + 1
    assert result is None or isinstance(result, UploadIncompleteError | LineError), result
    assert line.controller.executions["FB"] <= 1
    line.recovers()
    if result is None:
        assert line.client.download_job(1, "NEW.JOB").lines == LINES


# -- a cut line, and reconnecting ----------------------------------------------------------------
@pytest.fixture
def served() -> Iterator[tuple[VirtualController, FaultInjector, SimServer]]:
    controller = VirtualController(sim_config(ack_timeout=ACK_TIMEOUT))
    faults = FaultInjector(controller, seed=1)
    with SimServer(faults) as server:
        yield controller, faults, server


def test_a_cut_line_raises_at_once_and_reconnect_reopens_it(
    served: tuple[VirtualController, FaultInjector, SimServer],
) -> None:
    controller, faults, server = served
    with Client(server.url, timeout=1.0, reconnect=True) as client:
        assert client.status()[0].ready
        faults.schedule("disconnect", "to_host", at_byte=2)
        started = time.monotonic()
        with pytest.raises(PortError):
            client.status()
        assert time.monotonic() - started < 0.9  # at once, not after the reply timeout
        assert client.status()[0].ready  # reopened
        faults.schedule("disconnect", "to_host", at_byte=0)
        with pytest.raises(OutcomeUnknownError) as caught:
            client.set_speed(1, 200)
        assert isinstance(caught.value.__cause__, PortError)
        assert controller.executions["CB"] == 1
        assert client.speed(1) == 200
        assert controller.executions["CB"] == 1


def test_without_reconnect_a_cut_line_stays_cut(
    served: tuple[VirtualController, FaultInjector, SimServer],
) -> None:
    _, faults, server = served
    with Client(server.url, timeout=1.0) as client:
        faults.schedule("disconnect", "to_host", at_byte=0)
        with pytest.raises(PortError):
            client.status()
        with pytest.raises(PortError, match="reconnect=True"):
            client.status()
