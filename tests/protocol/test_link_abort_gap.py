"""The host's quiet gap after its own abort: the whole gap for any request but a stop.

After the host's own RST (Ctrl-C, a cancelled task) an answer may still be on its way through a
device server with latency. A request other than a stop waits the whole ``resync_gap``, so that
answer meets RST instead of landing on it; a stop (CF, CD, CI, BG) goes out after
``abort_gap``. A stop's answer is a bare flag, so data arriving in its exchange is the aborted
exchange's and is ignored; after an early stop the whole gap runs again before anything else.
The clock is set by hand, as in the other test_link_*.py files.
"""

from __future__ import annotations

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robostar.commands.control import EmergencyStop, StopHoming, StopJob
from robostar.commands.motion import JogStop
from robostar.protocol.frame import ACK, RST, encode_packet
from robostar.protocol.link import (
    EARLY_CODES,
    STOP_CODES,
    AnswerReceived,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    HostLink,
    Ignored,
    LinkEvent,
    State,
)
from robostar.protocol.packets import Shape

ACK_B = bytes((ACK,))
RST_B = bytes((RST,))
GR10 = b"\xffGR0   10"  # a read whose answer carries data
GR10_ANSWER = b"0  1010"
GR20 = b"\xffGR0   20"
GR20_ANSWER = b"0  2020"
CF = b"\xffCF"
OK = b"0"
END = b"4"
ABORT_AT = 0.1


def frame(data: bytes) -> bytes:
    return encode_packet(data)


def answers(events: list[LinkEvent]) -> list[bytes]:
    return [e.data for e in events if isinstance(e, AnswerReceived)]


def _aborted() -> HostLink:
    """A host whose GR read (sent at 0.0) it aborted itself at ABORT_AT: RST sent."""
    host = HostLink()
    assert host.abort_gap < host.resync_gap
    host.send_request(GR10, Shape.SINGLE, 0.0)
    assert host.data_to_send() == frame(GR10)
    [failed] = host.abort(ABORT_AT)
    assert isinstance(failed, ExchangeFailed) and failed.reason is FailReason.ABORTED
    assert host.data_to_send() == RST_B
    assert host.state is State.RESYNC
    return host


def test_the_stops_are_the_line_servers_stops() -> None:
    codes = {cls.CODE.encode("ascii") for cls in (EmergencyStop, StopJob, StopHoming, JogStop)}
    assert codes == STOP_CODES
    serve_line = pytest.importorskip("robostar.serve.line")
    assert {cls.CODE.encode("ascii") for cls in serve_line.STOPS} == STOP_CODES


def test_after_its_own_abort_a_read_waits_the_whole_gap() -> None:
    host = _aborted()
    assert host.next_deadline() == pytest.approx(ABORT_AT + host.resync_gap)
    assert host.send_request(GR20, Shape.SINGLE, ABORT_AT + 0.01) == []
    assert host.data_to_send() == b""
    # Past abort_gap: still quiet (before the fix, GR20 went out here).
    assert host.handle_timeout(ABORT_AT + host.abort_gap) == []
    assert host.data_to_send() == b""
    # The aborted read's answer arrives late (a device server held it): RST, the gap again.
    late = ABORT_AT + 0.2
    events = host.receive_data(frame(GR10_ANSWER), late)
    assert events == [Ignored("stale packet in the resync gap (RST)", State.RESYNC)]
    assert host.data_to_send() == RST_B
    assert host.handle_timeout(ABORT_AT + host.resync_gap) == []
    assert host.data_to_send() == b""
    assert host.next_deadline() == pytest.approx(late + host.resync_gap)
    assert host.handle_timeout(late + host.resync_gap) == []
    assert host.data_to_send() == frame(GR20)
    events = host.receive_data(frame(GR20_ANSWER), late + host.resync_gap + 0.01)
    assert answers(events) == [GR20_ANSWER]


def test_a_stop_asked_for_at_once_goes_out_after_abort_gap() -> None:
    host = _aborted()
    assert host.send_request(CF, Shape.SINGLE, ABORT_AT + 0.01, once=True) == []
    assert host.data_to_send() == b""
    assert host.next_deadline() == pytest.approx(ABORT_AT + host.abort_gap)
    assert host.handle_timeout(ABORT_AT + host.abort_gap - 0.0001) == []
    assert host.data_to_send() == b""
    assert host.handle_timeout(ABORT_AT + host.abort_gap) == []
    assert host.data_to_send() == frame(CF)
    assert host.state is State.WAIT_ANSWER


def test_a_stop_asked_for_after_abort_gap_goes_out_at_once() -> None:
    host = _aborted()
    at = ABORT_AT + host.abort_gap + 0.01
    assert host.send_request(CF, Shape.SINGLE, at, once=True) == []
    assert host.data_to_send() == frame(CF)
    assert host.state is State.WAIT_ANSWER


def test_a_stale_packet_before_abort_gap_holds_the_stop_back_too() -> None:
    host = _aborted()
    host.send_request(CF, Shape.SINGLE, ABORT_AT + 0.01, once=True)
    host.receive_data(frame(GR10_ANSWER), ABORT_AT + 0.03)
    assert host.data_to_send() == RST_B
    assert host.handle_timeout(ABORT_AT + host.abort_gap) == []
    assert host.data_to_send() == b""
    assert host.handle_timeout(ABORT_AT + 0.03 + host.abort_gap) == []
    assert host.data_to_send() == frame(CF)


@pytest.mark.parametrize("stale", [GR10_ANSWER, END], ids=["data", "END"])
def test_stale_data_is_not_taken_for_a_stops_answer(stale: bytes) -> None:
    host = _aborted()
    at = ABORT_AT + host.abort_gap
    host.send_request(CF, Shape.SINGLE, at, once=True)
    assert host.data_to_send() == frame(CF)
    # The aborted read's answer (or a transfer's END) arrives: a stop answers a bare flag.
    events = host.receive_data(frame(stale), at + 0.2)
    assert events == [Ignored("stale packet with data in a stop's answer", State.WAIT_ANSWER)]
    assert host.data_to_send() == b""  # not ACKed
    assert host.state is State.WAIT_ANSWER
    # The stop's own answer.
    events = host.receive_data(frame(OK), at + 0.3)
    assert events == [AnswerReceived(OK, 0x30, final=True), ExchangeComplete()]
    assert host.data_to_send() == ACK_B


def test_after_an_early_stop_the_whole_gap_runs_before_a_read() -> None:
    # The residual case: the aborted exchange's answer was a bare OK (a write's), taken for the
    # stop's. The stop's own answer then comes after the stop ended: it meets RST in the gap,
    # not the read after the stop.
    host = _aborted()
    at = ABORT_AT + host.abort_gap
    host.send_request(CF, Shape.SINGLE, at, once=True)
    host.data_to_send()
    events = host.receive_data(frame(OK), at + 0.2)  # stale, but a bare OK
    assert events == [AnswerReceived(OK, 0x30, final=True), ExchangeComplete()]
    assert host.data_to_send() == ACK_B
    assert host.state is State.RESYNC
    assert host.next_deadline() == pytest.approx(at + 0.2 + host.resync_gap)
    assert host.send_request(GR20, Shape.SINGLE, at + 0.21) == []
    assert host.data_to_send() == b""
    host.receive_data(frame(OK), at + 0.3)  # the stop's own answer
    assert host.data_to_send() == RST_B
    assert host.handle_timeout(at + 0.3 + host.resync_gap) == []
    assert host.data_to_send() == frame(GR20)


def test_after_an_early_stop_another_stop_still_goes_at_once() -> None:
    host = _aborted()
    at = ABORT_AT + host.abort_gap
    host.send_request(CF, Shape.SINGLE, at, once=True)
    host.data_to_send()
    host.receive_data(frame(OK), at + 0.2)
    host.data_to_send()
    assert host.state is State.RESYNC
    host.send_request(b"\xffCD0", Shape.SINGLE, at + 0.21, once=True)
    assert host.data_to_send() == frame(b"\xffCD0")


def test_an_early_stop_that_times_out_leaves_the_whole_gap() -> None:
    host = _aborted()
    at = ABORT_AT + host.abort_gap
    host.send_request(CF, Shape.SINGLE, at, once=True)
    host.data_to_send()
    events = host.handle_timeout(at + host.timeout)
    assert [e.reason for e in events if isinstance(e, ExchangeFailed)] == [FailReason.TIMEOUT]
    assert host.data_to_send() == RST_B
    assert host.state is State.RESYNC
    # Not our own abort: a stop waits the whole gap too.
    host.send_request(CF, Shape.SINGLE, at + host.timeout + 0.06, once=True)
    assert host.data_to_send() == b""
    assert host.next_deadline() == pytest.approx(at + host.timeout + host.resync_gap)


def test_after_a_timeout_a_stop_waits_the_whole_gap() -> None:
    host = HostLink()
    host.send_request(GR10, Shape.SINGLE, 0.0)
    host.data_to_send()
    host.handle_timeout(2.0)
    assert host.data_to_send() == RST_B
    host.send_request(CF, Shape.SINGLE, 2.01, once=True)
    assert host.handle_timeout(2.0 + host.abort_gap) == []
    assert host.data_to_send() == b""
    host.handle_timeout(2.0 + host.resync_gap)
    assert host.data_to_send() == frame(CF)


def test_aborting_a_deferred_stop_keeps_the_whole_gap() -> None:
    host = _aborted()
    host.send_request(CF, Shape.SINGLE, ABORT_AT + 0.01, once=True)
    assert host.next_deadline() == pytest.approx(ABORT_AT + host.abort_gap)
    [failed] = host.abort(ABORT_AT + 0.02)
    assert isinstance(failed, ExchangeFailed) and failed.state is State.RESYNC
    assert host.next_deadline() == pytest.approx(ABORT_AT + host.resync_gap)
    host.send_request(GR20, Shape.SINGLE, ABORT_AT + 0.03)
    assert host.handle_timeout(ABORT_AT + host.abort_gap) == []
    assert host.data_to_send() == b""


BF = b"\xffBF1"  # a running jog's keepalive on channel 1


def test_a_jogs_keepalive_goes_out_after_the_short_gap_like_a_stop() -> None:
    """The controller stops a jog that gets no BF within 500 ms; the whole gap (the reply
    timeout, 2 s) would stop it. BF answers a bare flag, so it is let out early as the stops."""
    assert b"BF" in EARLY_CODES and STOP_CODES < EARLY_CODES
    host = _aborted()
    host.send_request(BF, Shape.SINGLE, ABORT_AT + host.abort_gap / 2)
    assert host.data_to_send() == b""  # not before abort_gap
    host.handle_timeout(ABORT_AT + host.abort_gap)
    assert host.data_to_send() == frame(BF)
    # A stale answer with data is not taken as BF's
    events = host.receive_data(frame(GR10_ANSWER), ABORT_AT + host.abort_gap + 0.01)
    assert answers(events) == [] and any(isinstance(e, Ignored) for e in events)
    events = host.receive_data(frame(OK), ABORT_AT + host.abort_gap + 0.02)
    assert answers(events) == [OK]


@pytest.mark.parametrize("packet", [b"", b"\xff"], ids=["empty", "dummy byte alone"])
def test_a_packet_without_a_flag_in_an_early_stop_breaks_a_rule_not_the_link(
    packet: bytes,
) -> None:
    """A hostile or broken controller answering an early stop with a packet that holds no
    flag: the rule is broken (RST, ExchangeFailed), as outside an early stop; nothing raises."""
    host = _aborted()
    host.send_request(CF, Shape.SINGLE, ABORT_AT + host.abort_gap)
    assert host.data_to_send() == frame(CF)
    events = host.receive_data(frame(packet), ABORT_AT + host.abort_gap + 0.01)
    [failed] = [e for e in events if isinstance(e, ExchangeFailed)]
    assert failed.reason is FailReason.RULE
    assert host.data_to_send() == RST_B


def test_a_request_after_the_whole_gap_is_not_early_and_goes_at_once() -> None:
    """Nobody woke the link when its gap ended (a blocking client between calls): a stop long
    after is an ordinary request (data in its answer is not ignored as stale), and a request
    after it goes out at once, with no second gap."""
    host = _aborted()
    later = ABORT_AT + 100.0
    host.send_request(CF, Shape.SINGLE, later)
    assert host.data_to_send() == frame(CF)
    events = host.receive_data(frame(OK), later + 0.01)
    assert answers(events) == [OK] and host.data_to_send() == ACK_B
    assert host.state is State.IDLE
    host.send_request(GR20, Shape.SINGLE, later + 0.02)
    assert host.data_to_send() == frame(GR20)
    host2 = _aborted()
    host2.send_request(GR20, Shape.SINGLE, later)  # a read, too, goes at once
    assert host2.data_to_send() == frame(GR20)


_POOL = [
    frame(OK),
    frame(b"\xff" + OK),
    frame(GR10_ANSWER),
    frame(GR20_ANSWER),
    frame(END),
    frame(b""),
    frame(b"\xff"),
    frame(b"2"),
    frame(b"9"),
    ACK_B,
    RST_B,
    bytes((0x15,)),  # NAK
    frame(GR10_ANSWER)[:3],  # a frame cut short
    b"\x00junk",
]
_STEPS = st.sampled_from([0.0, 0.01, 0.03, 0.06, 0.3, 2.5])  # around abort_gap and the gaps
_OPS = st.one_of(
    st.tuples(st.just("send"), st.sampled_from([GR10, CF, BF]), _STEPS),
    st.tuples(st.just("abort"), st.none(), _STEPS),
    st.tuples(st.just("receive"), st.sampled_from(_POOL), _STEPS),
    st.tuples(st.just("tick"), st.none(), _STEPS),
)


@settings(max_examples=400)
@given(st.lists(_OPS, max_size=30))
@example(
    [("send", GR10, 0.0), ("abort", None, 0.0), ("send", CF, 0.06), ("receive", frame(b""), 0.0)]
)
@example(
    [
        ("send", GR10, 0.0),
        ("abort", None, 0.0),
        ("send", BF, 0.06),
        ("receive", frame(b"\xff"), 0.0),
    ]
)
def test_aborts_stops_and_any_controller_input_never_raise_nor_wedge_the_link(
    ops: list[tuple[str, bytes | None, float]],
) -> None:
    """Aborts, early and late stops, keepalives and whatever a controller sends, in any order
    and timing: the link never raises, and whenever it is not idle a timer runs, so that
    time alone brings it back to idle."""
    host = HostLink()
    now = 0.0
    for op, data, dt in ops:
        now += dt
        if op == "send" and data is not None:
            if host.idle or (host.state is State.RESYNC and host._deferred is None):
                host.send_request(data, Shape.SINGLE, now, once=data != GR10)
        elif op == "abort" and (host.busy or host._deferred is not None):
            host.abort(now)
        elif op == "receive" and data is not None:
            host.receive_data(data, now)
        elif op == "tick":
            deadline = host.next_deadline()
            if deadline is not None and deadline <= now:
                host.handle_timeout(now)
        host.data_to_send()
        if not host.idle:
            assert host.next_deadline() is not None, host.state
    for _ in range(200):  # time alone ends everything
        deadline = host.next_deadline()
        if deadline is None:
            break
        now = max(now, deadline)
        host.handle_timeout(now)
        host.data_to_send()
    assert host.idle and host._deferred is None
