"""Property tests of the link: a HostLink and a ControllerLink over a lossy in-memory line.

Hypothesis picks a run of exchanges of every shape and single-byte faults (drop, corrupt,
duplicate) on either direction of the line; the clock is advanced by hand from one event to the
next. Whatever the faults, no exception comes out of the links, every exchange ends by the
host's deadline (the host is no longer busy, though it may be in its RESYNC gap), and after the
faults stop a clean exchange succeeds. Where the faults are ones the protocol can see
(:data:`DETECTABLE`), a completed exchange delivered exactly the packets the controller sent for
it, and no request reached the controller's application twice.

The host application sends its next request as soon as the previous exchange has ended, failed
or not: it is the link's own RESYNC gap that keeps a late NAK or resend of the old exchange off
the new one.

And with no line at all, the same bytes cut into reads differently. The application acts after
each read, and line input that arrives in its turn waits for its call; if that input shows that
the peer moved on (an RST, a packet), the call sends nothing. So a read boundary changes what a
link does exactly where it falls inside a turn before such input: read together, the input
cancels the application's packet; read later, it finds the packet sent. And whatever the reads,
a link never sends its application's packet once it has read such input in the turn.
"""

from __future__ import annotations

import enum
import os
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TypeVar

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from robostar.errors import RobostarError
from robostar.protocol.frame import (
    ACK,
    ETX,
    NAK,
    RST,
    STX,
    Control,
    ControlKind,
    FrameDecoder,
    FrameEvent,
    Packet,
    encode_packet,
    lrc,
)
from robostar.protocol.link import (
    APP_TURN,
    TRANSITIONS,
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    Fence,
    HostLink,
    Input,
    Link,
    LinkEvent,
    RequestReceived,
    Role,
    State,
    UploadPacketReceived,
    UploadReady,
)
from robostar.protocol.packets import Shape

CONTROL = frozenset((ACK, NAK, RST))
FRAMING = frozenset((STX, ETX)) | CONTROL
WORK_TIME = 0.3
"""Seconds the controller works between a two-phase exchange's first and second answer."""
WAIT_DIGITS = b"01"
"""The two-phase first answer's expected wait, seconds (DB/DC style)."""
REFUSAL = b"\xff2"
"""The controller's answer to an FB packet it refuses."""
MAX_STEPS = 20_000


# -- the exchanges --------------------------------------------------------------------------------
def _steer(data: bytes) -> bytes:
    """Pad ``data`` so that its LRC is not a framing byte.

    A lone LRC byte seen between frames (its STX lost) that happened to be ACK, NAK or RST would
    be a control byte no check can tell from a real one. Choosing the data avoids it.
    """
    pad = ord("a")
    while lrc(data) in FRAMING - {ETX}:
        data += bytes((pad,))
        pad += 1
    return data


@dataclass(frozen=True)
class Exchange:
    number: int
    shape: Shape
    answers: tuple[bytes, ...] = ()
    """The controller's answer packets, in order (two-phase: first and second)."""
    lines: tuple[bytes, ...] = ()
    """FB: the content lines the host uploads."""
    refuse_at: int | None = None
    """FB: the host packet the controller refuses (0 the request, k the k-th line, then END)."""

    @property
    def request(self) -> bytes:
        return _steer(b"\xffT%c%02d" % (b"SMTU"[list(Shape).index(self.shape)], self.number))


FENCE_ANSWERS = {
    _steer(b"\xffZA"): _steer(b"0FA"),
    _steer(b"\xffZB"): _steer(b"0FB"),
}
"""The host's fences (read after an exchange it gave up) and the controller's answers to them:
no exchange of the plan answers alike."""
FENCES = tuple(
    Fence(request, lambda data, answer=answer: data == answer)
    for request, answer in FENCE_ANSWERS.items()
)


@st.composite
def exchange(draw: st.DrawFn, number: int) -> Exchange:
    shape = draw(st.sampled_from(list(Shape)))
    tag = b"%02d" % number
    error = draw(st.sampled_from([None, None, None, b"1", b"2", b"3"]))
    if shape is Shape.SINGLE:
        flag = error or b"0"
        return Exchange(number, shape, (_steer(flag + b"S" + tag),))
    if shape is Shape.MULTI:
        count = draw(st.integers(min_value=0, max_value=3))
        body = tuple(_steer(b"0M" + tag + b".%d" % i) for i in range(count))
        return Exchange(number, shape, (*body, error or b"4"))
    if shape is Shape.TWO_PHASE:
        if error:
            return Exchange(number, shape, (error,))
        return Exchange(number, shape, (b"0" + WAIT_DIGITS, _steer(b"0T" + tag)))
    count = draw(st.integers(min_value=0, max_value=3))
    lines = tuple(_steer(b"L" + tag + b".%d\n" % i) for i in range(count))
    refuse_at = draw(st.integers(min_value=0, max_value=count + 1)) if error else None
    return Exchange(number, shape, (REFUSAL,) if error else (), lines, refuse_at)


@st.composite
def exchanges(draw: st.DrawFn) -> tuple[Exchange, ...]:
    count = draw(st.integers(min_value=1, max_value=5))
    return tuple(draw(exchange(i)) for i in range(count))


# -- the lossy line -------------------------------------------------------------------------------
class Kind(enum.Enum):
    DROP = "drop"
    CORRUPT = "corrupt"
    DUPLICATE = "duplicate"


@dataclass(frozen=True)
class Fault:
    kind: Kind
    mask: int = 0  # CORRUPT: XOR mask, never 0


faults = st.one_of(
    st.just(Fault(Kind.DROP)),
    st.just(Fault(Kind.DUPLICATE)),
    st.integers(min_value=1, max_value=255).map(lambda m: Fault(Kind.CORRUPT, m)),
)


def byte_roles(chunk: bytes) -> list[tuple[str, int]]:
    """What each byte a link wrote is, and where its frame starts in ``chunk``: part of a frame
    (``stx``/``data``/``etx``/``lrc``) or a lone ``control`` byte (-1). Links write whole frames
    and control bytes only."""
    roles: list[tuple[str, int]] = []
    i = 0
    while i < len(chunk):
        if chunk[i] == STX:
            end = chunk.index(ETX, i)
            roles += [(role, i) for role in ("stx", *["data"] * (end - i - 1), "etx", "lrc")]
            i = end + 2
        else:
            roles.append(("control", -1))
            i += 1
    assert len(roles) == len(chunk)
    return roles


@dataclass(frozen=True)
class FaultModel:
    name: str
    allowed: Callable[[str, int, Fault], bool]
    one_per_frame: bool


def _detectable(role: str, byte: int, fault: Fault) -> bool:
    if role == "control":
        return fault.kind is Kind.DROP
    if fault.kind is Kind.CORRUPT:
        return byte ^ fault.mask not in FRAMING
    return True


ANY = FaultModel("any", lambda role, byte, fault: True, one_per_frame=False)
"""Every fault hypothesis picks, on any byte."""

DETECTABLE = FaultModel("detectable", _detectable, one_per_frame=True)
"""Faults the protocol can see, so that exactly-once delivery can be asked of the link:

- A lone control byte carries no check: one turned into another (NAK into ACK) or doubled (two
  ACKs acknowledge the next packet before it is sent) cannot be told from the real thing. Such
  a byte may only be lost.
- A frame byte may be lost, doubled or changed, except changed into a framing byte: a new ETX
  or STX in the middle of a frame cuts off a part whose XOR can match by chance (the LRC is one
  byte), and it would pass as a whole, shorter packet.
- One fault per frame: the LRC sees any single changed, lost or doubled byte, but two faults
  can cancel out (two equal bytes lost leave the XOR as it was).
"""


@dataclass
class Line:
    """One direction: each byte written gets its fault (by its index in this direction's
    stream) and arrives ``latency`` seconds later."""

    faults: dict[int, Fault]
    model: FaultModel
    latency: float
    written: int = 0
    in_flight: deque[tuple[float, bytes]] = field(default_factory=deque)
    applied: list[tuple[int, str, Fault]] = field(default_factory=list)

    def write(self, chunk: bytes, now: float) -> None:
        if not chunk:
            return
        out = bytearray()
        hit: set[int] = set()
        for byte, (role, start) in zip(chunk, byte_roles(chunk), strict=True):
            fault = self.faults.get(self.written)
            self.written += 1
            if (
                fault is None
                or not self.model.allowed(role, byte, fault)
                or (self.model.one_per_frame and start in hit)
            ):
                out.append(byte)
                continue
            if start >= 0:
                hit.add(start)
            self.applied.append((self.written - 1, role, fault))
            if fault.kind is Kind.DUPLICATE:
                out += bytes((byte, byte))
            elif fault.kind is Kind.CORRUPT:
                out.append(byte ^ fault.mask)
        if out:
            self.in_flight.append((now + self.latency, bytes(out)))

    def next_arrival(self) -> float | None:
        return self.in_flight[0][0] if self.in_flight else None

    def arrived(self, now: float) -> bytes:
        out = bytearray()
        while self.in_flight and self.in_flight[0][0] <= now:
            out += self.in_flight.popleft()[1]
        return bytes(out)


# -- the two applications -------------------------------------------------------------------------
@dataclass
class Outcome:
    exchange: Exchange
    completed: bool
    delivered: list[bytes]
    ready: int  # FB: UploadReady events
    started: float
    ended: float


@dataclass
class HostApp:
    """Runs the planned exchanges one after another, as a client would: each request goes to
    the link as soon as the previous exchange has ended (the link defers it during its gap)."""

    link: HostLink
    plan: tuple[Exchange, ...]
    outcomes: list[Outcome] = field(default_factory=list)
    current: Exchange | None = None
    delivered: list[bytes] = field(default_factory=list)
    ready: int = 0
    lines_sent: int = 0
    started: float = 0.0

    def take(self, events: list[LinkEvent], now: float) -> None:
        for event in events:
            if isinstance(event, AnswerReceived):
                assert self.current is not None
                self.delivered.append(event.data)
            elif isinstance(event, UploadReady):
                assert self.current is not None
                self.ready += 1
            elif isinstance(event, ExchangeComplete | ExchangeFailed):
                assert self.current is not None, event
                completed = isinstance(event, ExchangeComplete)
                self.outcomes.append(
                    Outcome(self.current, completed, self.delivered, self.ready, self.started, now)
                )
                self.current = None

    def act(self, now: float) -> None:
        link = self.link
        if self.current is None and len(self.outcomes) < len(self.plan):
            # The last exchange has ended, so the link has none open.
            assert not link.busy, link.state
            self.current = self.plan[len(self.outcomes)]
            self.delivered, self.ready, self.lines_sent, self.started = [], 0, 0, now
            self.take(link.send_request(self.current.request, self.current.shape, now), now)
        elif link.state is State.UPLOAD_READY:
            assert self.current is not None
            if self.lines_sent < len(self.current.lines):
                line = self.current.lines[self.lines_sent]
                self.lines_sent += 1
                self.take(link.send_upload_line(line, now), now)
            else:
                self.take(link.send_upload_end(now), now)

    @property
    def done(self) -> bool:
        return len(self.outcomes) == len(self.plan) and self.current is None


@dataclass
class ControllerApp:
    """Answers each request from the plan, as the simulator would."""

    link: ControllerLink
    plan: dict[bytes, Exchange]
    handled: list[bytes] = field(default_factory=list)
    uploads: dict[int, list[bytes]] = field(default_factory=dict)
    request: bytes = b""
    upload_end: bool = False
    upload_packets: int = 0
    second_due: float | None = None

    def take(self, events: list[LinkEvent]) -> None:
        for event in events:
            if isinstance(event, RequestReceived):
                self.request = event.data
                self.handled.append(event.data)
                self.second_due = None
                self.upload_packets = 0
                self.upload_end = False
                exchange = self.plan.get(event.data)
                if exchange is not None and exchange.shape is Shape.UPLOAD:
                    self.uploads[exchange.number] = []
            elif isinstance(event, UploadPacketReceived):
                exchange = self.plan.get(self.request)
                assert exchange is not None
                self.upload_end = event.end
                self.upload_packets += 1
                if not event.end:
                    self.uploads[exchange.number].append(event.data)
            elif isinstance(event, ExchangeFailed):
                self.second_due = None

    def act(self, now: float) -> None:
        link = self.link
        exchange = self.plan.get(self.request)
        if link.state is State.HANDLING:
            if exchange is None:
                answer = FENCE_ANSWERS.get(self.request, b"1")
                self.take(link.send_answer([answer], After.DONE, now))
            elif exchange.shape is Shape.UPLOAD:
                self.upload_reply(exchange, now)
            elif exchange.shape is Shape.TWO_PHASE and len(exchange.answers) == 2:
                self.second_due = now + WORK_TIME
                self.take(link.send_answer([exchange.answers[0]], After.SECOND_PHASE, now))
            else:
                self.take(link.send_answer(list(exchange.answers), After.DONE, now))
        elif link.state is State.UPLOAD_HANDLING:
            assert exchange is not None
            self.upload_reply(exchange, now)
        elif self.next_due() is not None and now >= (self.second_due or 0.0):
            assert exchange is not None
            self.second_due = None
            self.take(link.send_answer([exchange.answers[1]], After.DONE, now))

    def upload_reply(self, exchange: Exchange, now: float) -> None:
        link = self.link
        if self.upload_packets == exchange.refuse_at:
            self.take(link.send_answer([REFUSAL], After.FINAL, now))
        elif self.upload_end:
            self.take(link.accept_upload(now))
        else:
            self.take(link.send_answer([b"\xff0"], After.UPLOAD, now))

    def next_due(self) -> float | None:
        return self.second_due if self.link.state is State.WORKING else None


# -- the run --------------------------------------------------------------------------------------
HOST_WAITING = frozenset(
    state for role, state, what in TRANSITIONS if role is Role.HOST and what is Input.TIMEOUT
)


@dataclass
class Run:
    host: HostLink
    ctl: ControllerLink
    host_app: HostApp
    ctl_app: ControllerApp
    up: Line
    down: Line
    now: float = 0.0
    errors: list[RobostarError] = field(default_factory=list)

    @classmethod
    def build(
        cls,
        plan: tuple[Exchange, ...],
        up_faults: dict[int, Fault],
        down_faults: dict[int, Fault],
        model: FaultModel,
        latency: float,
    ) -> Run:
        host, ctl = HostLink(fences=FENCES), ControllerLink()
        return cls(
            host,
            ctl,
            HostApp(host, plan),
            ControllerApp(ctl, {e.request: e for e in plan}),
            Line(up_faults, model, latency),
            Line(down_faults, model, latency),
        )

    def guarded(self, call: Callable[[], None]) -> None:
        try:
            call()
        except RobostarError as error:  # recorded for the test to check; others propagate
            self.errors.append(error)

    def check_host_timer(self) -> None:
        # A host waiting on the line always has a deadline; one waiting on its application none.
        if self.host.state in HOST_WAITING:
            assert self.host.next_deadline() is not None, self.host.state
        else:
            assert self.host.next_deadline() is None, self.host.state

    def check_deadline_passed(self, state: State, now: float) -> None:
        host, current = self.host, self.host_app.current
        if state is not State.RESYNC:
            # Every exchange ends by the host's deadline: nothing keeps it open past it.
            assert not host.busy, host.state
        elif current is None:
            # The end of the gap, with no request deferred: idle.
            assert host.idle, host.state
        else:
            # The end of the gap: the deferred request (or the fence before it) has gone out,
            # with a fresh timer.
            waiting = (
                State.UPLOAD_WAIT_REPLY if current.shape is Shape.UPLOAD else State.WAIT_ANSWER
            )
            assert host.state in (waiting, State.WAIT_FENCE), host.state
            assert host.next_deadline() == now + host.timeout

    def step(self) -> bool:
        """Act, write, advance the clock to the next event and deliver; False when quiet."""
        self.guarded(lambda: self.host_app.act(self.now))
        self.guarded(lambda: self.ctl_app.act(self.now))
        self.up.write(self.host.data_to_send(), self.now)
        self.down.write(self.ctl.data_to_send(), self.now)
        self.check_host_timer()
        times = [
            t
            for t in (
                self.up.next_arrival(),
                self.down.next_arrival(),
                self.host.next_deadline(),
                self.ctl.next_deadline(),
                self.ctl_app.next_due(),
            )
            if t is not None
        ]
        if not times:
            return False
        self.now = max(self.now, min(times))
        now = self.now
        self.guarded(lambda: self.ctl_app.take(self.ctl.receive_data(self.up.arrived(now), now)))
        self.guarded(
            lambda: self.host_app.take(self.host.receive_data(self.down.arrived(now), now), now)
        )
        deadline = self.host.next_deadline()
        state = self.host.state
        self.guarded(lambda: self.host_app.take(self.host.handle_timeout(now), now))
        if deadline is not None and now >= deadline:
            self.check_deadline_passed(state, now)
        self.guarded(lambda: self.ctl_app.take(self.ctl.handle_timeout(now)))
        return True

    def run(self) -> None:
        for _ in range(MAX_STEPS):
            if not self.step():
                break
        else:
            pytest.fail("the links never went quiet")
        assert self.host_app.done, "an exchange never ended"
        assert self.host.idle and self.ctl.idle


def check_liveness(run: Run) -> None:
    """With the faults gone, a fresh exchange on the same links succeeds."""
    run.up.faults.clear()
    run.down.faults.clear()
    final = Exchange(99, Shape.MULTI, (_steer(b"0Zfinal"), b"4"))
    run.host_app.plan += (final,)
    run.ctl_app.plan[final.request] = final
    run.run()
    last = run.host_app.outcomes[-1]
    assert last.exchange == final
    assert last.completed
    assert last.delivered == list(final.answers)


def check_exactly_once(run: Run) -> None:
    app = run.ctl_app
    for outcome in run.host_app.outcomes:
        exchange = outcome.exchange
        if not outcome.completed:
            continue
        assert outcome.delivered == list(exchange.answers), exchange
        if exchange.shape is Shape.UPLOAD:
            # Every line reached the controller once, in order, up to a refusal.
            refused = len(exchange.lines) + 1 if exchange.refuse_at is None else exchange.refuse_at
            assert app.uploads[exchange.number] == list(exchange.lines[:refused]), exchange
            assert outcome.ready == refused, exchange
    # A request reaches the controller's application at most once: a state-changing command
    # never runs twice. (A fence is a read, sent after each exchange given up.)
    handled = [request for request in app.handled if request not in FENCE_ANSWERS]
    assert len(handled) == len(set(handled)), app.handled


scenario = st.tuples(
    exchanges(),
    st.dictionaries(st.integers(min_value=0, max_value=120), faults, max_size=4),
    st.dictionaries(st.integers(min_value=0, max_value=250), faults, max_size=4),
    st.sampled_from([0.0, 0.004, 0.05]),
)

EXAMPLES = int(os.environ.get("ROBOSTAR_PROPERTY_EXAMPLES", "300"))
"""Examples per property test: 300 in the suite; ``reliability/run.py properties --examples N``
runs many more, not derandomized."""
SETTINGS = settings(
    max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)


@SETTINGS
@given(scenario)
def test_any_single_byte_faults_never_wedge_the_links(
    case: tuple[tuple[Exchange, ...], dict[int, Fault], dict[int, Fault], float],
) -> None:
    plan, up_faults, down_faults, latency = case
    run = Run.build(plan, up_faults, down_faults, ANY, latency)
    run.run()
    assert run.errors == []
    assert len(run.host_app.outcomes) == len(plan)
    assert all(o.ended >= o.started for o in run.host_app.outcomes)
    check_liveness(run)


_DROP = Fault(Kind.DROP)

OLD_ANSWER_RESENT_ONTO_A_NEW_REQUEST = (
    (
        Exchange(0, Shape.SINGLE, (b"0S00",)),
        Exchange(1, Shape.SINGLE, (b"0S01",)),
    ),
    {8: _DROP, 9: _DROP},
    {0: _DROP, 7: _DROP},
    0.0,
)
"""Found by hypothesis's random search. The answer lost, the host's RST lost, the
controller's next resend damaged, the host's next request lost: the controller's following
resend of the old answer reached the host while it waited for the new request's answer, and
was taken for it. Closed by the fence (the timeout gave the exchange up, so the next request
waits behind a read only the controller's answer to it can pass for)."""

END_OF_A_MULTI_PACKET_ANSWER_ONTO_THE_NEXT_REQUEST = (
    (
        Exchange(0, Shape.UPLOAD, (), (b"L00.0\n",)),
        Exchange(1, Shape.MULTI, (b"0M01.0", b"0M01.1", b"4")),
        Exchange(2, Shape.SINGLE, (b"0S02",)),
    ),
    {39: _DROP, 32: _DROP},
    {},
    0.004,
)
"""Found by hypothesis's random search. The ACK of a multi-packet answer's END and the next
request's ETX lost: the controller, its frame decoder holding the broken request, resent END
three times; the host ACKed each as a resend and, when nothing else came, took END for the
single request's answer. A copy taken for a slow controller's answer now must come once (a
resending controller repeats it) and fit the exchange (END ends only a multi-packet answer)."""


@SETTINGS
@example(OLD_ANSWER_RESENT_ONTO_A_NEW_REQUEST)
@example(END_OF_A_MULTI_PACKET_ANSWER_ONTO_THE_NEXT_REQUEST)
@given(scenario)
def test_detectable_faults_deliver_each_answer_exactly_once(
    case: tuple[tuple[Exchange, ...], dict[int, Fault], dict[int, Fault], float],
) -> None:
    plan, up_faults, down_faults, latency = case
    run = Run.build(plan, up_faults, down_faults, DETECTABLE, latency)
    run.run()
    assert run.errors == []
    check_exactly_once(run)
    check_liveness(run)


@given(exchanges(), st.sampled_from([0.0, 0.004, 0.05]))
def test_a_clean_line_completes_every_exchange_exactly(
    plan: tuple[Exchange, ...], latency: float
) -> None:
    run = Run.build(plan, {}, {}, ANY, latency)
    run.run()
    assert run.errors == []
    assert [o.completed for o in run.host_app.outcomes] == [True] * len(plan)
    check_exactly_once(run)
    assert run.ctl_app.handled == [e.request for e in plan]


def test_byte_roles() -> None:
    chunk = bytes((ACK,)) + encode_packet(b"0AB") + bytes((NAK,))
    assert [role for role, _ in byte_roles(chunk)] == [
        "control",
        *("stx", "data", "data", "data", "etx", "lrc"),
        "control",
    ]
    assert {start for _, start in byte_roles(chunk)} == {-1, 1}


def test_the_line_applies_each_fault_to_its_byte() -> None:
    faults_ = {0: Fault(Kind.DROP), 2: Fault(Kind.DUPLICATE), 3: Fault(Kind.CORRUPT, 0x01)}
    line = Line(faults_, ANY, 0.5)
    line.write(bytes.fromhex("02 41 42 03 03"), 1.0)
    assert line.next_arrival() == 1.5
    assert line.arrived(1.4) == b""
    assert line.arrived(1.5) == bytes.fromhex("41 42 42 02 03")
    assert [index for index, _, _ in line.applied] == [0, 2, 3]


def test_the_detectable_model_spares_what_no_check_can_see() -> None:
    # A control byte may only be lost; a frame byte never becomes a framing byte; one fault a
    # frame.
    faults_ = {
        0: Fault(Kind.DUPLICATE),
        1: Fault(Kind.CORRUPT, ACK ^ NAK),
        2: Fault(Kind.DROP),
        4: Fault(Kind.CORRUPT, 0x41 ^ ETX),
        5: Fault(Kind.CORRUPT, 0x01),
        7: Fault(Kind.DROP),
    }
    line = Line(faults_, DETECTABLE, 0.0)
    line.write(bytes((ACK, NAK, ACK)) + bytes.fromhex("02 41 42 03 03"), 0.0)
    assert line.arrived(0.0) == bytes((ACK, NAK)) + bytes.fromhex("02 41 43 03 03")
    assert [index for index, _, _ in line.applied] == [2, 5]


# -- read boundaries ------------------------------------------------------------------------------
UPLOAD_REQUEST = b"\xffFB0      RS.JOB001"
LINE_INPUT = [
    bytes((ACK,)),
    bytes((NAK,)),
    bytes((RST,)),
    bytes.fromhex("02 30 41 03 00"),  # a bad LRC
    bytes.fromhex("02 30 41") + encode_packet(b"0"),  # a frame cut short by the next
]
CONTROLLER_INPUT = st.sampled_from(
    [
        *LINE_INPUT,
        *(encode_packet(d) for d in (b"\xffAA", b"\xffAB", UPLOAD_REQUEST, b"0L\n", b"4", b"0")),
    ]
)
HOST_INPUT = st.sampled_from(
    [*LINE_INPUT, *(encode_packet(d) for d in (b"\xff0", b"\xff2", b"0S", b"4", b"9"))]
)


class RecordingDecoder(FrameDecoder):
    """A FrameDecoder that keeps every event it has given out, in order."""

    def __init__(self) -> None:
        super().__init__()
        self.given: list[FrameEvent] = []

    def feed(self, data: bytes | bytearray | memoryview) -> list[FrameEvent]:
        events = super().feed(data)
        self.given += events
        return events


class Traced(Link):
    """A link that notes where each of its application's turns started: the place, among the
    frame events it has read, of the packet that started it."""

    decoder: RecordingDecoder

    def __init__(self) -> None:
        super().__init__()
        self.decoder = RecordingDecoder()
        self.turn_starts: list[int] = []

    def _dispatch_frame(self, event: FrameEvent) -> None:
        in_turn = self.state in APP_TURN
        super()._dispatch_frame(event)
        if self.state in APP_TURN and not in_turn:
            assert isinstance(event, Packet)  # a new object each: found by identity
            given = self.decoder.given
            self.turn_starts.append(max(i for i, e in enumerate(given) if e is event))

    def read_in_turn(self) -> list[FrameEvent]:
        """What has been read since the packet that started the current turn."""
        return self.decoder.given[self.turn_starts[-1] + 1 :]


class TracedController(Traced, ControllerLink):
    pass


class TracedHost(Traced, HostLink):
    pass


def moved_on(event: FrameEvent) -> bool:
    """Input that shows the peer moved on when it arrives in the application's turn."""
    return isinstance(event, Packet) or event == Control(ControlKind.RST)


Call = tuple[list[LinkEvent], bytes]
"""What an application's call returned, and the bytes it sends first if its packet goes out."""


def controller_turn(link: ControllerLink, events: list[LinkEvent]) -> Call:
    """The controller application's call in its turn, from the last event it was given."""
    last = events[-1]
    if isinstance(last, UploadPacketReceived) and last.end:
        return link.accept_upload(0.0), bytes((ACK,))
    if isinstance(last, UploadPacketReceived) or last == RequestReceived(UPLOAD_REQUEST):
        return link.send_answer([b"\xff0"], After.UPLOAD, 0.0), encode_packet(b"\xff0")
    return link.send_answer([b"0x", b"4"], After.DONE, 0.0), encode_packet(b"0x")


def host_turn(link: HostLink, events: list[LinkEvent]) -> Call:
    """The host application's call in its turn: a line after the first reply, then the end."""
    if sum(isinstance(e, UploadReady) for e in events) < 2:
        return link.send_upload_line(b"L\n", 0.0), encode_packet(b"0L\n")
    return link.send_upload_end(0.0), encode_packet(b"4")


def check_call(read: list[FrameEvent], packet: bytes, out: bytes) -> None:
    """An application's call, after ``read`` in its turn, wrote ``out``: its ``packet`` first
    if nothing showed that the peer moved on, else nothing but refusals (RST, NAK)."""
    if any(moved_on(event) for event in read):
        assert set(out) <= {RST, NAK}, (read, out)
    else:
        assert out.startswith(packet), (read, out)


def drive(
    link: Traced,
    chunks: list[bytes],
    turn: Callable[[list[LinkEvent]], Call],
    *,
    check: bool = False,
) -> tuple[list[object], bytes, State]:
    """Feed ``chunks`` as separate reads; the application acts after each read whenever it is
    its turn (with ``check``, each call is checked by :func:`check_call`). Returns the events
    (a rule break's error by its message: exceptions compare by identity), the bytes written
    and the state at the end."""
    events: list[LinkEvent] = []
    written = b""
    for chunk in chunks:
        events += link.receive_data(chunk, 0.0)
        written += link.data_to_send()
        while link.state in APP_TURN:
            read = link.read_in_turn()
            returned, packet = turn(events)
            out = link.data_to_send()
            if check:
                check_call(read, packet, out)
            events += returned
            written += out
    comparable: list[object] = [
        (replace(e, error=None), str(e.error))
        if isinstance(e, ExchangeFailed) and e.error is not None
        else e
        for e in events
    ]
    return comparable, written, link.state


def reads(inputs: list[tuple[bytes, bool]]) -> list[bytes]:
    """Whole frames and control bytes, a read ending after each one marked True."""
    chunks: list[bytes] = []
    chunk = b""
    for data, read_ends in inputs:
        chunk += data
        if read_ends:
            chunks.append(chunk)
            chunk = b""
    return [*chunks, chunk]


def cut_short(inputs: list[tuple[bytes, bool]], link: Traced) -> set[int]:
    """Where, in the run of ``link`` that read all ``inputs`` at once, a read ending after the
    input of that index would fall inside a turn, before the input that cut it short.

    In that run the application acts in each turn with the whole rest of the stream read, so a
    turn is cut short by the first RST or packet after the packet that started it, if there is
    one; a read ending before that input lets the application act first."""
    owner = [i for i, (data, _) in enumerate(inputs) for _ in FrameDecoder().feed(data)]
    assert len(owner) == len(link.decoder.given)
    movers = sorted({owner[j] for j, e in enumerate(link.decoder.given) if moved_on(e)})
    inside: set[int] = set()
    for start in {owner[j] for j in link.turn_starts}:
        mover = next((i for i in movers if i > start), None)
        if mover is not None:
            inside.update(range(start, mover))
    return inside


L = TypeVar("L", bound=Traced)


def check_read_boundaries(
    links: tuple[L, L], inputs: list[tuple[bytes, bool]], turn: Callable[[L, list[LinkEvent]], Call]
) -> None:
    """The first link reads ``inputs`` at once, the second in the reads they mark: the two do
    the same unless a read ends inside a turn cut short, and then they differ."""
    stream = b"".join(data for data, _ in inputs)
    whole = drive(links[0], [stream], lambda events: turn(links[0], events))
    split = drive(links[1], reads(inputs), lambda events: turn(links[1], events))
    inside = cut_short(inputs, links[0])
    cuts = {i for i, (_, read_ends) in enumerate(inputs[:-1]) if read_ends}
    if cuts & inside:
        # The application acted before input that, read with the rest, cancels its packet.
        assert split != whole
    else:
        assert split == whole


# Reads are cut between frames only: FrameDecoder's own tests cut inside frames, and a link that
# ends an exchange with RST drops the unfinished frame it is reading (see test_link_resync.py).
@given(st.lists(st.tuples(CONTROLLER_INPUT, st.booleans()), max_size=12))
def test_a_read_boundary_changes_what_the_controller_does_only_inside_a_turn_cut_short(
    inputs: list[tuple[bytes, bool]],
) -> None:
    links = TracedController(), TracedController()
    check_read_boundaries(links, inputs, controller_turn)


@given(st.lists(st.tuples(HOST_INPUT, st.booleans()), max_size=12))
def test_a_read_boundary_changes_what_the_host_does_only_inside_a_turn_cut_short(
    inputs: list[tuple[bytes, bool]],
) -> None:
    links = TracedHost(), TracedHost()
    for link in links:
        link.send_request(UPLOAD_REQUEST, Shape.UPLOAD, 0.0)
    check_read_boundaries(links, inputs, host_turn)


def anywhere(stream: bytes, draw: st.DataObject) -> list[bytes]:
    """``stream`` cut into reads at any bytes, inside frames too (empty reads included)."""
    cuts = sorted(draw.draw(st.lists(st.integers(min_value=0, max_value=len(stream)))))
    return [stream[a:b] for a, b in zip([0, *cuts], [*cuts, len(stream)], strict=True)]


@given(st.lists(CONTROLLER_INPUT, max_size=12), st.data())
def test_whatever_the_reads_the_controller_never_answers_once_the_host_moved_on(
    inputs: list[bytes], draw: st.DataObject
) -> None:
    # drive() checks each call against what was read in its turn.
    link = TracedController()
    chunks = anywhere(b"".join(inputs), draw)
    drive(link, chunks, lambda events: controller_turn(link, events), check=True)


@given(st.lists(HOST_INPUT, max_size=12), st.data())
def test_whatever_the_reads_the_host_never_sends_an_upload_packet_once_the_controller_moved_on(
    inputs: list[bytes], draw: st.DataObject
) -> None:
    link = TracedHost()
    link.send_request(UPLOAD_REQUEST, Shape.UPLOAD, 0.0)
    chunks = anywhere(b"".join(inputs), draw)
    drive(link, chunks, lambda events: host_turn(link, events), check=True)
