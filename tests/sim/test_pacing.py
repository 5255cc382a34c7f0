"""Tests of line timing: bytes take 10 bit times each way, answers leave after the turnaround.

Every test drives the paced peer with a fake clock (plain numbers), so the wire times are
checked exactly and nothing sleeps.
"""

from __future__ import annotations

import pytest

from robostar.errors import UsageError
from robostar.protocol.frame import encode_packet
from robostar.protocol.link import After, ControllerLink, RequestReceived
from robostar.sim.pacing import PacedPeer
from robostar.transport.peer import BytePeer

BAUD = 1000  # 10 ms a byte: round numbers
BYTE = 0.01
REQUEST = encode_packet(b"\xffAA")  # 6 bytes
ANSWER_DATA = b"\x30\xb5\x80\x80"
ANSWER = encode_packet(ANSWER_DATA)  # 7 bytes


class Recorder:
    """Keeps each byte it receives with the time it was given; sends what the test queues."""

    def __init__(self) -> None:
        self.arrivals: list[tuple[float, int]] = []
        self.outbox = bytearray()
        self.deadline: float | None = None
        self.polls: list[float] = []
        self.clock: list[float] = []  # every time given, in call order

    @property
    def received(self) -> bytes:
        return bytes(b for _, b in self.arrivals)

    def feed(self, data: bytes, now: float) -> None:
        self.clock.append(now)
        self.arrivals += [(now, b) for b in data]

    def output(self, now: float) -> bytes:
        self.clock.append(now)
        self.polls.append(now)
        if self.deadline is not None and now >= self.deadline:
            self.deadline = None
        out = bytes(self.outbox)
        self.outbox.clear()
        return out

    def next_deadline(self) -> float | None:
        return self.deadline


class Answerer:
    """The real controller link answering every request at once (its clock is recorded)."""

    def __init__(self) -> None:
        self.link = ControllerLink(timeout=2.0)
        self.request_times: list[float] = []

    def feed(self, data: bytes, now: float) -> None:
        for event in self.link.receive_data(data, now):
            if isinstance(event, RequestReceived):
                self.request_times.append(now)
                self.link.send_answer([ANSWER_DATA], After.DONE, now)

    def output(self, now: float) -> bytes:
        self.link.handle_timeout(now)
        return self.link.data_to_send()

    def next_deadline(self) -> float | None:
        return self.link.next_deadline()


def test_a_paced_peer_is_a_byte_peer() -> None:
    paced = PacedPeer(Recorder())
    assert isinstance(paced, BytePeer)
    assert paced.byte_time == pytest.approx(10 / 115200)


def test_host_bytes_reach_the_peer_one_byte_time_apart() -> None:
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD)
    paced.feed(b"abcde", 1.0)
    assert rec.arrivals == []
    assert paced.next_deadline() == pytest.approx(1.05)
    paced.output(1.0199)
    assert rec.received == b"a"
    paced.output(1.02)
    assert rec.received == b"ab"
    paced.output(5.0)
    assert [t for t, _ in rec.arrivals] == pytest.approx([1.01, 1.02, 1.03, 1.04, 1.05])
    assert rec.received == b"abcde"
    assert paced.next_deadline() is None


def test_late_polling_still_gives_each_byte_its_own_time() -> None:
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD)
    paced.feed(b"xyz", 0.0)
    paced.output(100.0)
    assert [t for t, _ in rec.arrivals] == pytest.approx([0.01, 0.02, 0.03])


def test_a_busy_line_queues_the_next_write_behind_the_first() -> None:
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD)
    paced.feed(b"ab", 0.0)
    paced.feed(b"c", 0.005)  # written while "a" is still on the wire
    paced.output(1.0)
    assert [t for t, _ in rec.arrivals] == pytest.approx([0.01, 0.02, 0.03])


def test_an_idle_line_starts_a_write_at_once() -> None:
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD)
    paced.feed(b"a", 0.0)
    paced.output(0.5)
    paced.feed(b"b", 0.5)
    paced.output(1.0)
    assert [t for t, _ in rec.arrivals] == pytest.approx([0.01, 0.51])


def test_peer_output_leaves_after_the_turnaround_at_wire_speed() -> None:
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD, turnaround=0.1)
    rec.outbox += b"XYZ"
    assert paced.output(2.0) == b""
    assert paced.next_deadline() == pytest.approx(2.13)
    assert paced.output(2.1099) == b""
    assert paced.output(2.11) == b"X"
    assert paced.output(2.125) == b"Y"
    assert paced.output(2.13) == b"Z"
    assert paced.next_deadline() is None


def test_polling_long_before_a_burst_starts_releases_nothing() -> None:
    # Regression: a poll well inside the turnaround once released most of a long burst early
    # and then again, so the host saw duplicated bytes and bad LRCs.
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD, turnaround=0.1)
    rec.outbox += b"ABCDEFG"
    assert paced.output(0.0) == b""
    assert paced.output(0.05) == b""
    assert paced.output(0.1) == b""
    assert paced.output(0.13) == b"ABC"
    assert paced.output(0.17) == b"DEFG"


def test_output_produced_while_the_line_is_busy_follows_back_to_back() -> None:
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD, turnaround=0.001)
    rec.outbox += b"AB"
    assert paced.output(0.0) == b""  # on the wire from 0.001 to 0.021
    rec.outbox += b"C"
    assert paced.output(0.005) == b""  # ready at 0.006, but the line is busy
    assert paced.output(0.0309) == b"AB"
    assert paced.output(0.031) == b"C"


def test_each_burst_waits_its_own_turnaround() -> None:
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD, turnaround=0.1)
    rec.outbox += b"AB"
    assert paced.output(0.0) == b""  # on the wire from 0.10 to 0.12
    rec.outbox += b"C"
    assert paced.output(0.115) == b"A"  # C is ready at 0.215
    assert paced.output(0.2249) == b"B"
    assert paced.output(0.225) == b"C"


def test_a_request_is_answered_at_the_wire_times_of_a_real_line() -> None:
    controller = Answerer()
    paced = PacedPeer(controller, baud=BAUD, turnaround=0.002)
    paced.feed(REQUEST, 0.0)
    request_done = len(REQUEST) * BYTE
    answer_done = request_done + 0.002 + len(ANSWER) * BYTE
    assert paced.next_deadline() == pytest.approx(request_done)
    assert paced.output(request_done) == b""
    assert controller.request_times == pytest.approx([request_done])
    assert paced.next_deadline() == pytest.approx(answer_done)
    assert paced.output(answer_done - 0.001) == ANSWER[:-1]
    assert paced.output(answer_done) == ANSWER[-1:]


def test_the_answer_time_does_not_depend_on_when_the_caller_polls() -> None:
    # Polled only long after the request crossed the wire, the answer still leaves as if the
    # controller had answered when the last byte arrived.
    controller = Answerer()
    paced = PacedPeer(controller, baud=BAUD)
    paced.feed(REQUEST, 0.0)
    assert paced.output(0.0605) == ANSWER[:0]
    assert controller.request_times == pytest.approx([0.06])
    assert paced.output(0.09) == ANSWER[:3]


def test_peer_deadlines_fire_in_time_order_with_arriving_bytes() -> None:
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD)
    rec.deadline = 0.025
    paced.feed(b"abcd", 0.0)
    assert paced.next_deadline() == pytest.approx(0.025)
    paced.output(1.0)
    # The peer was polled at its deadline, between the 2nd and 3rd byte, not only at the end.
    assert 0.025 in rec.polls
    times = [t for t, _ in rec.arrivals]
    assert times == pytest.approx([0.01, 0.02, 0.03, 0.04])
    assert rec.polls == sorted(rec.polls)


def test_a_peer_deadline_that_never_moves_does_not_hang() -> None:
    class Stuck(Recorder):
        def next_deadline(self) -> float | None:
            return 0.5

    paced = PacedPeer(Stuck(), baud=BAUD)
    assert paced.output(1.0) == b""
    assert paced.next_deadline() == 0.5


def test_the_wrapped_peer_never_sees_time_run_backwards() -> None:
    rec = Recorder()
    paced = PacedPeer(rec, baud=BAUD, turnaround=0.05)
    rec.deadline = 0.015
    rec.outbox += b"Q"
    paced.feed(b"ab", 0.0)
    paced.output(0.012)
    paced.feed(b"cdef", 0.012)
    paced.output(0.3)
    paced.feed(b"g", 0.3)
    paced.output(0.4)
    assert len(rec.clock) > 8
    assert rec.clock == sorted(rec.clock)
    assert rec.clock[-1] == pytest.approx(0.4)


@pytest.mark.parametrize("baud", [0, -9600, 9600.5, True, "9600"])
def test_a_bad_baud_is_refused(baud: object) -> None:
    with pytest.raises(UsageError, match="baud"):
        PacedPeer(Recorder(), baud=baud)  # type: ignore[arg-type]


@pytest.mark.parametrize("turnaround", [-0.001, float("nan"), float("inf"), "0.1"])
def test_a_bad_turnaround_is_refused(turnaround: object) -> None:
    with pytest.raises(UsageError, match="turnaround"):
        PacedPeer(Recorder(), turnaround=turnaround)  # type: ignore[arg-type]
