"""Tests of the fault injector: each kind at its exact byte, spec strings, seeds, counters."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.errors import UsageError
from robostar.protocol.frame import (
    ACK,
    NAK,
    RST,
    CorruptPacket,
    CorruptReason,
    FrameDecoder,
    Packet,
    encode_packet,
)
from robostar.protocol.link import (
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    HostLink,
    LinkEvent,
    RequestReceived,
)
from robostar.protocol.packets import Shape
from robostar.sim.faults import (
    Direction,
    FaultInjector,
    FaultKind,
    FaultSpec,
    parse_fault,
)
from robostar.transport.peer import BytePeer

REQUEST = encode_packet(b"\xffAA")
ANSWER = encode_packet(b"\x30\xb5\x80\x80")


class Recorder:
    """An inner peer that keeps what it receives and sends what the test puts in ``outbox``."""

    def __init__(self) -> None:
        self.received = bytearray()
        self.outbox = bytearray()

    def feed(self, data: bytes, now: float) -> None:
        self.received += data

    def output(self, now: float) -> bytes:
        out = bytes(self.outbox)
        self.outbox.clear()
        return out

    def next_deadline(self) -> float | None:
        return None


class CannedController:
    """An inner peer on the real controller link that answers every request with ANSWER."""

    def __init__(self) -> None:
        self.link = ControllerLink(timeout=2.0)
        self.requests: list[bytes] = []

    def feed(self, data: bytes, now: float) -> None:
        for event in self.link.receive_data(data, now):
            if isinstance(event, RequestReceived):
                self.requests.append(event.data)
                self.link.send_answer([ANSWER[1:-2]], After.DONE, now)

    def output(self, now: float) -> bytes:
        self.link.handle_timeout(now)
        return self.link.data_to_send()

    def next_deadline(self) -> float | None:
        return self.link.next_deadline()


def answer_through(injector: FaultInjector, rec: Recorder, now: float = 0.0) -> bytes:
    """Send REQUEST, let the inner peer answer ANSWER, return what reaches the host."""
    injector.feed(REQUEST, now)
    rec.outbox += ANSWER
    return injector.output(now)


def run_exchange(peer: BytePeer, *, limit: float = 20.0) -> list[LinkEvent]:
    """A whole AA exchange by a real host link against ``peer`` on a fake clock."""
    host = HostLink(timeout=2.0)
    now = 0.0
    events = host.send_request(b"\xffAA", Shape.SINGLE, now)
    while now < limit:
        wire = host.data_to_send()
        if wire:
            peer.feed(wire, now)
        out = peer.output(now)
        if out:
            events += host.receive_data(out, now)
        events += host.handle_timeout(now)
        wire = host.data_to_send()
        if wire:
            peer.feed(wire, now)
        if any(isinstance(e, ExchangeComplete | ExchangeFailed) for e in events):
            return events
        now = round(now + 0.01, 6)
    raise AssertionError("the exchange never ended")


# -- the wrapper is a byte peer --------------------------------------------------------------
def test_without_faults_bytes_pass_unchanged() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    assert isinstance(injector, BytePeer)
    assert answer_through(injector, rec) == ANSWER
    assert bytes(rec.received) == REQUEST
    assert injector.total() == 0


# -- every byte kind at every position of the answer ----------------------------------------
@pytest.mark.parametrize("k", range(len(ANSWER)))
def test_drop_to_host_removes_exactly_byte_k(k: int) -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.DROP, Direction.TO_HOST, at_byte=k)
    assert answer_through(injector, rec) == ANSWER[:k] + ANSWER[k + 1 :]
    assert injector.injected[FaultKind.DROP, Direction.TO_HOST] == 1
    assert injector.pending == ()


@pytest.mark.parametrize("k", range(len(REQUEST)))
def test_drop_to_controller_removes_exactly_byte_k(k: int) -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule("drop", "to_controller", at_byte=k)
    injector.feed(REQUEST, 0.0)
    assert bytes(rec.received) == REQUEST[:k] + REQUEST[k + 1 :]


@pytest.mark.parametrize("k", range(len(ANSWER)))
def test_corrupt_flips_the_given_bits_of_byte_k(k: int) -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.CORRUPT, at_byte=k, mask=0x41)
    got = answer_through(injector, rec)
    want = bytearray(ANSWER)
    want[k] ^= 0x41
    assert got == bytes(want)


@pytest.mark.parametrize("k", range(len(ANSWER)))
def test_corrupt_without_a_mask_changes_only_byte_k(k: int) -> None:
    rec = Recorder()
    injector = FaultInjector(rec, seed=7)
    injector.schedule(FaultKind.CORRUPT, at_byte=k)
    got = answer_through(injector, rec)
    assert len(got) == len(ANSWER)
    assert [i for i in range(len(got)) if got[i] != ANSWER[i]] == [k]


@pytest.mark.parametrize("k", range(len(ANSWER)))
def test_duplicate_doubles_byte_k(k: int) -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.DUPLICATE, at_byte=k)
    assert answer_through(injector, rec) == ANSWER[: k + 1] + ANSWER[k:]


@pytest.mark.parametrize("k", range(len(ANSWER)))
def test_rst_goes_in_before_byte_k(k: int) -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.RST, at_byte=k)
    assert answer_through(injector, rec) == ANSWER[:k] + bytes((RST,)) + ANSWER[k:]


@pytest.mark.parametrize("k", range(len(ANSWER)))
def test_delay_holds_the_answer_from_byte_k(k: int) -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.DELAY, at_byte=k, seconds=0.5)
    assert answer_through(injector, rec, now=10.0) == ANSWER[:k]
    assert injector.next_deadline() == 10.5
    assert injector.output(10.49) == b""
    assert injector.output(10.5) == ANSWER[k:]
    assert injector.next_deadline() is None


def test_bytes_produced_during_a_delay_keep_their_order() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.DELAY, at_byte=2, seconds=1.0)
    assert answer_through(injector, rec) == ANSWER[:2]
    rec.outbox += b"\x06"
    assert injector.output(0.5) == b""
    assert injector.output(1.0) == ANSWER[2:] + b"\x06"
    rec.outbox += b"\x15"
    assert injector.output(1.2) == b"\x15"  # the hold is over


@pytest.mark.parametrize("k", range(len(ANSWER)))
def test_disconnect_cuts_the_line_at_byte_k_until_taken(k: int) -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.DISCONNECT, at_byte=k)
    assert answer_through(injector, rec) == ANSWER[:k]
    assert injector.disconnect_requested
    injector.feed(b"\x06", 0.1)  # the host's bytes are lost too
    assert bytes(rec.received) == REQUEST
    assert injector.take_disconnect() is True
    assert injector.take_disconnect() is False
    assert answer_through(injector, rec, now=1.0) == ANSWER
    assert bytes(rec.received) == REQUEST * 2


def test_count_hits_consecutive_bytes() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.add("drop:to_host@3*4")
    assert answer_through(injector, rec) == ANSWER[:3] + ANSWER[7:]
    assert injector.injected[FaultKind.DROP, Direction.TO_HOST] == 4


# -- packet-level kinds ----------------------------------------------------------------------
def test_corrupt_lrc_spoils_only_the_lrc_and_the_receiver_refuses_it() -> None:
    rec = Recorder()
    injector = FaultInjector(rec, seed=1)
    injector.schedule(FaultKind.CORRUPT_LRC)
    got = answer_through(injector, rec)
    assert got[:-1] == ANSWER[:-1]
    assert got[-1] != ANSWER[-1]
    (event,) = FrameDecoder().feed(got)
    assert isinstance(event, CorruptPacket)
    assert event.reason is CorruptReason.BAD_LRC


def test_corrupt_lrc_for_the_next_n_packets() -> None:
    rec = Recorder()
    injector = FaultInjector(rec, seed=2)
    injector.schedule(FaultKind.CORRUPT_LRC, count=2)
    injector.feed(REQUEST, 0.0)
    rec.outbox += ANSWER * 3
    events = FrameDecoder().feed(injector.output(0.0))
    assert [type(e) for e in events] == [CorruptPacket, CorruptPacket, Packet]


@given(
    data=st.binary(min_size=0, max_size=40).map(
        lambda b: b.replace(b"\x02", b"").replace(b"\x03", b"")
    ),
    seed=st.integers(0, 2**32),
)
def test_a_spoiled_lrc_is_always_refused(data: bytes, seed: int) -> None:
    # Includes data whose XOR is zero, where the receiver also takes 0x03 for the LRC.
    rec = Recorder()
    injector = FaultInjector(rec, seed=seed)
    injector.schedule(FaultKind.CORRUPT_LRC)
    injector.feed(REQUEST, 0.0)
    rec.outbox += encode_packet(data)
    events = FrameDecoder().feed(injector.output(0.0))
    assert len(events) == 1
    assert isinstance(events[0], CorruptPacket)


def test_nak_storm_answers_the_next_packets_with_nak_instead_of_passing_them() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.NAK_STORM, count=2)
    for attempt in range(2):
        injector.feed(REQUEST, float(attempt))
        assert injector.output(float(attempt)) == bytes((NAK,))
        assert rec.received == b""
    injector.feed(REQUEST, 2.0)
    assert bytes(rec.received) == REQUEST
    assert injector.injected[FaultKind.NAK_STORM, Direction.TO_CONTROLLER] == 2


def test_nak_storm_answers_after_the_whole_packet_not_at_its_start() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.add("nak*1")
    injector.feed(REQUEST[:3], 0.0)
    assert injector.output(0.0) == b""
    injector.feed(REQUEST[3:], 0.0)
    assert injector.output(0.0) == bytes((NAK,))


def test_nak_storm_lets_control_bytes_through() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.add("nak*1")
    injector.feed(bytes((ACK,)), 0.0)
    assert bytes(rec.received) == bytes((ACK,))


# -- where counting starts -------------------------------------------------------------------
def test_positions_count_from_the_next_host_packet() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.DROP, Direction.TO_CONTROLLER, at_byte=0)
    injector.schedule(FaultKind.DROP, Direction.TO_HOST, at_byte=0)
    # A late ACK of the previous exchange and a stray controller byte are not part of it.
    injector.feed(bytes((ACK,)), 0.0)
    rec.outbox += bytes((NAK,))
    assert injector.output(0.0) == bytes((NAK,))
    assert injector.pending != ()
    assert answer_through(injector, rec) == ANSWER[1:]
    assert bytes(rec.received) == bytes((ACK,)) + REQUEST[1:]


def test_positions_run_on_across_packets_of_the_exchange() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    second = len(ANSWER) + 1  # the second packet's byte 1
    injector.schedule(FaultKind.DROP, Direction.TO_HOST, at_byte=second)
    injector.feed(REQUEST, 0.0)
    rec.outbox += ANSWER * 2
    assert injector.output(0.0) == ANSWER + ANSWER[:1] + ANSWER[2:]


def test_positions_do_not_depend_on_how_bytes_are_split() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.CORRUPT, Direction.TO_HOST, at_byte=4, mask=0xFF)
    injector.feed(REQUEST, 0.0)
    got = b""
    for byte in ANSWER:
        rec.outbox.append(byte)
        got += injector.output(0.0)
    want = bytearray(ANSWER)
    want[4] ^= 0xFF
    assert got == bytes(want)


# -- rates and seeds ---------------------------------------------------------------------------
def _noisy_run(seed: int, chunk: int) -> tuple[bytes, bytes]:
    rec = Recorder()
    injector = FaultInjector(rec, seed=seed)
    injector.add("corrupt:0.05")
    injector.add("drop:to_host:0.05")
    injector.add("dup:to_controller:0.05")
    stream = REQUEST * 50
    for i in range(0, len(stream), chunk):
        injector.feed(stream[i : i + chunk], 0.0)
    out = b""
    answers = ANSWER * 50
    for i in range(0, len(answers), chunk):
        rec.outbox += answers[i : i + chunk]
        out += injector.output(0.0)
    return bytes(rec.received), out


def test_rate_faults_are_repeatable_with_a_seed_however_bytes_are_split() -> None:
    first = _noisy_run(seed=42, chunk=1)
    assert first == _noisy_run(seed=42, chunk=7)
    assert first == _noisy_run(seed=42, chunk=1000)
    assert first != _noisy_run(seed=43, chunk=7)


def test_rate_faults_hit_at_about_their_rate() -> None:
    rec = Recorder()
    injector = FaultInjector(rec, seed=3)
    injector.add_rate(FaultKind.DROP, 0.1, Direction.TO_HOST)
    injector.feed(REQUEST, 0.0)
    rec.outbox += bytes(range(0x40, 0x80)) * 100  # 6400 bytes of noise, no framing
    got = injector.output(0.0)
    dropped = 6400 - len(got)
    assert injector.total(FaultKind.DROP) == dropped
    assert 500 < dropped < 800


def test_a_both_ways_rate_hits_both_directions() -> None:
    rec = Recorder()
    injector = FaultInjector(rec, seed=5)
    injector.add("corrupt:1")
    injector.feed(REQUEST, 0.0)
    rec.outbox += ANSWER
    got = injector.output(0.0)
    assert all(a != b for a, b in zip(got, ANSWER, strict=True))
    assert all(a != b for a, b in zip(rec.received, REQUEST, strict=True))
    assert injector.total(direction=Direction.TO_HOST) == len(ANSWER)
    assert injector.total(direction=Direction.TO_CONTROLLER) == len(REQUEST)


def test_clear_removes_faults_but_keeps_counts() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.add("drop:to_host:1")
    injector.schedule("rst", at_byte=50)
    assert answer_through(injector, rec) == b""
    injector.clear()
    assert injector.pending == ()
    assert answer_through(injector, rec) == ANSWER
    assert injector.total(FaultKind.DROP) == len(ANSWER)
    assert injector.log[-1].kind is FaultKind.DROP


# -- against the real link machines ----------------------------------------------------------
def test_a_spoiled_answer_lrc_is_naked_and_resent() -> None:
    controller = CannedController()
    injector = FaultInjector(controller, seed=0)
    injector.schedule(FaultKind.CORRUPT_LRC)
    events = run_exchange(injector)
    answers = [e for e in events if isinstance(e, AnswerReceived)]
    assert [a.data for a in answers] == [ANSWER[1:-2]]
    assert isinstance(events[-1], ExchangeComplete)
    assert injector.total(FaultKind.CORRUPT_LRC) == 1


def test_a_short_nak_storm_is_ridden_out_by_resending() -> None:
    controller = CannedController()
    injector = FaultInjector(controller)
    injector.add("nak*3")
    events = run_exchange(injector)
    assert isinstance(events[-1], ExchangeComplete)
    assert controller.requests == [b"\xffAA"]


def test_a_long_nak_storm_makes_the_host_give_up() -> None:
    controller = CannedController()
    injector = FaultInjector(controller)
    injector.add("nak*4")
    events = run_exchange(injector)
    assert isinstance(events[-1], ExchangeFailed)
    assert events[-1].reason is FailReason.NAK_LIMIT
    assert controller.requests == []


# -- spec strings ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("text", "want"),
    [
        ("corrupt:0.01", FaultSpec(FaultKind.CORRUPT, Direction.BOTH, rate=0.01)),
        ("drop:to_host:0.005", FaultSpec(FaultKind.DROP, Direction.TO_HOST, rate=0.005)),
        (
            "delay:0.5@3",
            FaultSpec(FaultKind.DELAY, Direction.TO_HOST, at_byte=3, seconds=0.5),
        ),
        (
            "delay:to_controller:0.2:0.1",
            FaultSpec(FaultKind.DELAY, Direction.TO_CONTROLLER, rate=0.1, seconds=0.2),
        ),
        ("corrupt", FaultSpec(FaultKind.CORRUPT, Direction.TO_HOST)),
        (
            "dup:to-controller@7*2",
            FaultSpec(FaultKind.DUPLICATE, Direction.TO_CONTROLLER, at_byte=7, count=2),
        ),
        ("nak*3", FaultSpec(FaultKind.NAK_STORM, Direction.TO_CONTROLLER, count=3)),
        ("corrupt-lrc*2", FaultSpec(FaultKind.CORRUPT_LRC, Direction.TO_HOST, count=2)),
        ("RST@12", FaultSpec(FaultKind.RST, Direction.TO_HOST, at_byte=12)),
        (
            "disconnect:to_host:0.001",
            FaultSpec(FaultKind.DISCONNECT, Direction.TO_HOST, rate=0.001),
        ),
    ],
)
def test_spec_strings_parse(text: str, want: FaultSpec) -> None:
    spec = parse_fault(text)
    assert spec == want
    assert parse_fault(str(spec)) == spec


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("", "fault"),
        ("explode:0.1", "not a fault kind"),
        ("corrupt:sideways:0.1", "not a number"),
        ("corrupt:1.5", "not in (0, 1]"),
        ("nak:3", "nak*3"),
        ("drop:0.1@3", "not both"),
        ("delay", "needs its seconds"),
        ("delay:0@1", "more than 0"),
        ("rst@2*3", "takes no *COUNT"),
        ("drop@x", "@AT"),
        ("drop*0", "1 or more"),
        ("drop:both@3", "one direction"),
        ("nak:to_host*2", "to_controller"),
        ("corrupt:0.1:0.2", "too many numbers"),
    ],
)
def test_bad_spec_strings_are_refused_with_a_clear_error(text: str, says: str) -> None:
    with pytest.raises(UsageError, match="fault") as caught:
        parse_fault(text)
    assert says in str(caught.value)


def test_bad_api_arguments_are_refused() -> None:
    injector = FaultInjector(Recorder())
    with pytest.raises(UsageError, match="fault kind"):
        injector.schedule("melt")
    with pytest.raises(UsageError, match="direction"):
        injector.schedule("drop", "sideways")
    with pytest.raises(UsageError, match="mask"):
        injector.schedule("corrupt", mask=0x100)
    with pytest.raises(UsageError, match="mask"):
        injector.schedule("drop", mask=1)
    with pytest.raises(UsageError, match="at_byte"):
        injector.schedule("drop", at_byte=-1)
    with pytest.raises(UsageError, match="rate"):
        injector.add_rate("drop", 0.0)
    with pytest.raises(UsageError, match="seconds"):
        injector.add_rate("delay", 0.5)
    assert injector.pending == ()


# -- a repeated previous answer, and answer latency (issues #11, #19) -------------------------
def test_repeat_sends_the_previous_answer_again_before_this_one() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    assert answer_through(injector, rec) == ANSWER  # the first answer passes
    injector.schedule(FaultKind.REPEAT)
    second = encode_packet(b"\x30\x84\x80\x80")
    injector.feed(REQUEST, 1.0)
    rec.outbox += second
    assert injector.output(1.0) == ANSWER + second
    assert injector.injected[FaultKind.REPEAT, Direction.TO_HOST] == 1


def test_repeat_with_no_previous_answer_sends_nothing_extra() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.schedule(FaultKind.REPEAT)
    assert answer_through(injector, rec) == ANSWER


def test_repeat_is_only_for_answers() -> None:
    with pytest.raises(UsageError, match="to_host"):
        FaultInjector(Recorder()).schedule(FaultKind.REPEAT, Direction.TO_CONTROLLER)


def test_a_fixed_latency_holds_every_answer_packet() -> None:
    rec = Recorder()
    injector = FaultInjector(rec)
    injector.add("latency:0.3")
    for start in (0.0, 5.0):
        injector.feed(REQUEST, start)
        rec.outbox += ANSWER
        assert injector.output(start) == b""
        assert injector.next_deadline() == pytest.approx(start + 0.3)
        assert injector.output(start + 0.2999) == b""
        assert injector.output(start + 0.3) == ANSWER


def test_a_jittered_latency_stays_within_its_bounds() -> None:
    rec = Recorder()
    injector = FaultInjector(rec, seed=11)
    injector.add("latency:0.5:0.1")
    holds = []
    for k in range(20):
        start = 10.0 * k
        injector.feed(REQUEST, start)
        rec.outbox += ANSWER
        injector.output(start)
        deadline = injector.next_deadline()
        assert deadline is not None
        holds.append(deadline - start)
        assert injector.output(deadline) == ANSWER
    assert all(0.1 - 1e-9 <= h <= 0.5 + 1e-9 for h in holds)
    assert max(holds) - min(holds) > 0.1  # it does jitter


@pytest.mark.parametrize(
    "spec", ["latency:0.3", "latency:0.5:0.1", "repeat", "repeat@3*2", "latency:0.2@0*4"]
)
def test_new_kinds_round_trip_through_their_spec(spec: str) -> None:
    parsed = parse_fault(spec)
    assert parse_fault(str(parsed)) == parsed


@pytest.mark.parametrize(
    "spec", ["latency", "latency:0.1:0.5", "repeat:0.5:to_host", "dup:0.1:0.2"]
)
def test_bad_new_specs_are_refused(spec: str) -> None:
    with pytest.raises(UsageError):
        parse_fault(spec)
