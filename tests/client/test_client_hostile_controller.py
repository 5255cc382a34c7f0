"""The client against a controller written as a script: doubled NAKs, endless answers, absurd
waits, repeated answers, slow controllers: none makes a command run twice, hang or grow
without bound.

The scripted controller answers by rules, byte for byte, through an in-process line: what it
receives and executes is counted, so "never twice" is checked at the controller.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import pytest

from robostar import Client
from robostar.errors import (
    AnswerTooLongError,
    LinkRuleError,
    OutcomeUnknownError,
    ReplyTimeoutError,
)
from robostar.protocol.frame import ACK, NAK, Control, FrameDecoder, Packet, encode_packet
from robostar.protocol.packets import make_answer
from robostar.transport import PeerTransport

pytestmark = pytest.mark.timeout(60)

OK = encode_packet(make_answer(0x30))
STATUS = encode_packet(make_answer(0x30, bytes((0x84, 0x84, 0x80))))
ALARM = encode_packet(make_answer(0x30, b"E1153 : T/P Emergency       "))
NAK_B, ACK_B = bytes((NAK,)), bytes((ACK,))

Reply = Iterable[tuple[float, bytes]]
"""(delay in seconds, bytes) the controller sends after a request."""


@dataclass
class Scripted:
    """A controller whose answer to the n-th request packet is ``script(data, n)``."""

    script: Callable[[bytes, int], Reply]
    on_ack: Callable[[int], Reply] = lambda n: ()
    requests: list[bytes] = field(default_factory=list)
    acks: int = 0
    resets: int = 0
    _decoder: FrameDecoder = field(default_factory=FrameDecoder)
    _queue: list[tuple[float, bytes]] = field(default_factory=list)

    def feed(self, data: bytes, now: float) -> None:
        for event in self._decoder.feed(data):
            if isinstance(event, Packet):
                self.requests.append(event.data)
                self._plan(now, self.script(event.data, len(self.requests)))
            elif isinstance(event, Control):
                if event.kind == ACK:
                    self.acks += 1
                    self._plan(now, self.on_ack(self.acks))
                elif event.kind != NAK:
                    self.resets += 1
                    self._queue.clear()

    def _plan(self, now: float, reply: Reply) -> None:
        self._queue += [(now + delay, data) for delay, data in reply]
        self._queue.sort(key=lambda item: item[0])

    def output(self, now: float) -> bytes:
        due = [data for at, data in self._queue if at <= now]
        self._queue = [(at, data) for at, data in self._queue if at > now]
        return b"".join(due)

    def next_deadline(self) -> float | None:
        return self._queue[0][0] if self._queue else None

    def executed(self, code: str) -> int:
        """Intact requests of ``code`` the controller took (NAKed copies are not taken)."""
        return sum(1 for data in self.requests if data[1:3] == code.encode())


def client(peer: Scripted, timeout: float = 0.3) -> Client:
    return Client(PeerTransport(peer), timeout=timeout, poll_interval=0.005)


# -- doubled NAK ----------------------------------------------------------------------------------
def test_a_doubled_nak_gives_one_resend_and_one_execution() -> None:
    # The first copy arrived damaged; the line doubled the controller's NAK byte.
    taken: list[int] = []

    def script(data: bytes, n: int) -> Reply:
        if n == 1:
            return [(0.0, NAK_B + NAK_B)]
        taken.append(n)
        return [(0.0, OK)]

    peer = Scripted(script)
    with client(peer) as robot:
        robot.set_speed(1, 40)
        time.sleep(0.05)  # a second copy, if one went out, would arrive now
    assert len(peer.requests) == 2  # the damaged copy and one resend
    assert taken == [2]


def test_a_late_doubled_nak_does_not_send_a_state_change_a_third_time() -> None:
    # The doubled NAK comes in a read of its own, after the resend went out: it may answer the
    # resend or repeat the first NAK. A state change is not sent again; the answer decides.
    def script(data: bytes, n: int) -> Reply:
        if n == 1:
            return [(0.0, NAK_B), (0.01, NAK_B)]
        return [(0.03, OK)]

    peer = Scripted(script)
    with client(peer) as robot:
        robot.write_global_int(5, 123)
    assert [data[1:3] for data in peer.requests] == [b"GW", b"GW"]


def test_a_late_nak_with_no_answer_is_an_unknown_outcome_not_a_third_copy() -> None:
    def script(data: bytes, n: int) -> Reply:
        return [(0.0, NAK_B)] if n <= 2 else [(0.0, OK)]

    peer = Scripted(script)
    with client(peer) as robot, pytest.raises(OutcomeUnknownError, match="not resent"):
        robot.write_global_int(5, 123)
    assert len(peer.requests) == 2


def test_a_read_survives_naks_with_a_resend_for_each() -> None:
    def script(data: bytes, n: int) -> Reply:
        return [(0.0, NAK_B)] if n <= 3 else [(0.0, STATUS)]

    peer = Scripted(script)
    with client(peer) as robot:
        assert robot.status()[0].servo_on is False
    assert len(peer.requests) == 4


# -- one overall limit per exchange -----------------------------------------------------------
def test_a_controller_repeating_its_previous_answer_cannot_hold_the_client() -> None:
    # The second CB is "answered" by a copy of the first answer again and again, each late
    # enough to pass for a resend. Every copy is ACKed; the exchange still ends at its limit.
    # The copies pass for resends only while the second request goes out right behind the ACK
    # of the first answer (within the link's resend_gap, 0.25 s); sent later, a copy is a slow
    # controller's answer to it (the rule is right). A machine so loaded that the client took
    # that long between the two is not this test's case: it is run again.
    for _ in range(5):
        acked: list[float] = []
        asked: list[float] = []

        def script(data: bytes, n: int, asked: list[float] = asked) -> Reply:
            asked.append(time.monotonic())
            if n == 1:
                return [(0.0, OK)]
            # 0.5 s apart: each well past the 0.27 s (90 % of the controller's 0.3 s resend
            # period) before which a copy is new data, and well within the 1 s reply timeout
            # (then 1.5 s with the resend grace), so that a loaded machine's late delivery of
            # one copy can neither bring the next under the one nor the first past the other
            return [(0.5 * k, OK) for k in range(1, 200)]

        def on_ack(n: int, acked: list[float] = acked) -> Reply:
            acked.append(time.monotonic())
            return ()

        peer = Scripted(script, on_ack)
        transport = PeerTransport(peer)
        with Client(transport, timeout=1.0, controller_timeout=0.3, poll_interval=0.005) as robot:
            robot.set_speed(1, 40)
            started = time.monotonic()
            try:
                robot.set_speed(1, 50)
            except OutcomeUnknownError as error:
                outcome: BaseException | None = error
            else:
                outcome = None
            took = time.monotonic() - started
        if asked[1] - acked[0] < 0.2:
            break
    else:
        pytest.skip("the machine never let the client send its request behind its ACK")
    assert isinstance(outcome, OutcomeUnknownError) and "overall limit" in str(outcome)
    # timeout x (3 NAKs + 1) + (timeout + grace) for its one packet, and slack for the machine
    assert took < 1.0 * 4 + 1.5 + 2.0


def test_a_trickle_of_noise_cannot_hold_the_client() -> None:
    # Damaged frames every 0.25 s: each is NAKed and each NAK used to restart the wait.
    bad = b"\x02\x30\x03\x00"
    script = lambda data, n: [(0.25 * k, bad) for k in range(1, 400)]  # noqa: E731
    peer = Scripted(script)
    started = time.monotonic()
    with client(peer) as robot, pytest.raises((ReplyTimeoutError, OutcomeUnknownError)):
        robot.set_speed(1, 50)
    assert time.monotonic() - started < 0.3 * 4 + 0.8 + 2.0


# -- two-phase waits -------------------------------------------------------------------------------
@pytest.mark.parametrize("wait", [b"99999999", b"1x", b"-1", b"100"])
def test_an_announced_wait_that_is_not_two_digits_is_a_protocol_error(wait: bytes) -> None:
    # DB is a state change the controller answered: a protocol error, and an unknown outcome
    first = encode_packet(make_answer(0x30, wait))
    peer = Scripted(lambda data, n: [(0.0, first)])
    started = time.monotonic()
    with (
        client(peer) as robot,
        pytest.raises(OutcomeUnknownError, match="not two digits") as caught,
    ):
        robot.servo(1, True)
    assert isinstance(caught.value.__cause__, LinkRuleError)
    assert time.monotonic() - started < 2.0
    assert peer.resets == 1  # the link said RST


def test_a_two_digit_wait_is_waited_for() -> None:
    first = encode_packet(make_answer(0x30, b"01"))
    peer = Scripted(lambda data, n: [(0.0, first), (0.5, OK)])
    with client(peer) as robot:
        assert robot.servo(1, True) == 1


# -- endless multi-packet answers -------------------------------------------------------------
def test_an_endless_alarm_list_is_cut_at_what_ab_can_carry() -> None:
    # AB holds at most ten alarms and END; this controller never sends END.
    peer = Scripted(lambda data, n: [(0.0, ALARM)] if n == 1 else [(0.0, STATUS)])
    peer.on_ack = lambda n: [(0.0, ALARM)]
    with client(peer) as robot:
        with pytest.raises(AnswerTooLongError, match="11 packets"):
            robot.alarms()
        assert peer.resets == 1
        assert peer.acks == 11
        peer.on_ack = lambda n: ()
        assert robot.status()[0].ready  # the line is clean again


# -- slow controllers (#19) ---------------------------------------------------------------------
@pytest.mark.parametrize("latency", [0.1, 0.3, 1.5])
def test_a_slow_controller_is_served_at_its_own_speed(latency: float) -> None:
    # Every AA is answered with the same bytes after ``latency``: each is the answer, not a
    # resend of the one before (the controller resends only after its own 2 s timeout).
    peer = Scripted(lambda data, n: [(latency, STATUS)])
    with client(peer, timeout=2.0) as robot:
        started = time.monotonic()
        for _ in range(3):
            assert robot.status()[0].ready
        took = time.monotonic() - started
    assert len(peer.requests) == 3  # no retry was needed
    assert took < 3 * latency + 1.5  # well short of a timeout per call


# -- an answer that breaks the protocol ----------------------------------------------------------
@pytest.mark.parametrize(
    "answer",
    [
        encode_packet(b"\x35"),  # a flag the protocol has not got
        encode_packet(b"\x34"),  # END, to a single exchange
    ],
)
def test_a_state_change_whose_answer_breaks_the_protocol_has_an_unknown_outcome(
    answer: bytes,
) -> None:
    peer = Scripted(lambda data, n: [(0.0, answer)])
    with client(peer) as robot, pytest.raises(OutcomeUnknownError, match="broke the protocol"):
        robot.set_speed(1, 50)
    assert peer.executed("CB") == 1


def test_a_read_whose_answer_breaks_the_protocol_is_a_protocol_error() -> None:
    peer = Scripted(lambda data, n: [(0.0, encode_packet(b"\x35"))])
    with client(peer) as robot, pytest.raises(LinkRuleError):
        robot.speed(1)
