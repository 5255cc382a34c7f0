"""The fault matrix: one exchange of each shape, one fault at each byte position, both ways.

A cell is (exchange, fault kind, direction, byte position). Each cell runs on a fresh simulator
behind a :class:`~robostar.sim.faults.FaultInjector`, reached by the real blocking
:class:`~robostar.Client` over the in-memory transport, on a virtual clock
(:mod:`reliability.vclock`). The fault is scheduled at the position, the exchange runs once,
then a normal AA exchange runs on the same client. A cell passes when:

- the call completed with the unfaulted run's result, the simulator carried a state-changing
  command out exactly once, and its state is the unfaulted run's; or
- it raised a robostar error, at most ``timeout`` after the line last moved, with the command
  carried out at most once and the state either untouched or as the unfaulted run left it;
- and in both cases the AA exchange after it succeeds. An FB upload the caller believes
  complete is read back with FA and must match.

Anything else is a violation, kept with the cell's byte trace.
"""

from __future__ import annotations

import functools
import itertools
import time
import zlib
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from reliability.vclock import Hang, RealClock, VirtualClock, virtual_time
from robostar.client import Client
from robostar.commands.base import Command, Shape
from robostar.commands.control import StartJob
from robostar.commands.files import DownloadFile, UploadFile
from robostar.commands.job import Servo
from robostar.commands.motion import MoveBy
from robostar.commands.status import ReadAlarms, ReadStatus
from robostar.commands.variables import ReadGlobalInt, WriteGlobalPoint
from robostar.errors import (
    LinkRuleError,
    OutcomeUnknownError,
    PortError,
    RobostarError,
    UploadIncompleteError,
)
from robostar.protocol.fields import FileName
from robostar.protocol.frame import ACK, ETX, STX, FrameDecoder, Packet, encode_packet
from robostar.sim import SimConfig, VirtualController
from robostar.sim.faults import Direction, FaultInjector, FaultKind, FaultSpec
from robostar.sim.filesystem import StoredJob
from robostar.transport.inproc import PeerTransport
from robostar.types import ArmForm, CoordSystem, JobFile, MotionType, Point

__all__ = [
    "CASES",
    "CI_STRIDE",
    "FAULTS",
    "SCENARIOS",
    "Baseline",
    "Case",
    "CellResult",
    "Fault",
    "MatrixConfig",
    "Scenario",
    "Trial",
    "baseline",
    "row",
    "rows",
    "run_cell",
    "run_matrix",
    "run_row",
    "run_scenario",
    "summarise",
]


# -- the line --------------------------------------------------------------------------------
class SimulatorCrash(BaseException):
    """The simulator raised while taking or giving bytes (a real server's thread would die)."""


class FaultLine(PeerTransport):
    """The in-memory transport with a fault injector at the far end, acting on its disconnect
    as the simulator's server does: the line drops at once (PortError), whatever the controller
    sends while it is down is lost, and a half-sent request is closed off so the next one is
    clean. It records the bytes both ways and when the line last moved."""

    def __init__(self, injector: FaultInjector, clock: VirtualClock) -> None:
        super().__init__(injector, url="sim://matrix", clock=clock.monotonic)
        self.injector = injector
        self.clock = clock
        self.trace: list[tuple[str, bytes]] = []
        self.last_activity = clock.now
        self.written = 0
        self.received = 0
        self._in_packet = False
        self._xor = 0
        self._after_etx = False

    def _peer(self, call: Callable[..., Any], *args: Any) -> Any:
        try:
            return call(*args)
        except Exception as exc:
            self.trace.append(("crash", repr(exc).encode()))
            raise SimulatorCrash(repr(exc)) from exc

    def open(self) -> None:
        # Bytes sent while nobody was connected are gone.
        self._peer(self.injector.output, self.clock.now)
        super().open()

    def _tail(self, data: bytes) -> None:
        for byte in data:
            if self._after_etx:
                self._after_etx = False
            elif byte == STX:
                self._in_packet, self._xor = True, 0
            elif self._in_packet and byte == ETX:
                self._in_packet, self._after_etx = False, True
            elif self._in_packet:
                self._xor ^= byte

    def _cut(self) -> PortError:
        self.injector.take_disconnect()
        wrong = self._xor ^ 0xFF
        closing = bytes((ETX, wrong)) if self._in_packet else b""
        closing = bytes((wrong,)) if self._after_etx else closing
        self._in_packet = self._after_etx = False
        if closing:
            self._peer(self.injector.feed, closing, self.clock.now)
        self._peer(self.injector.output, self.clock.now)
        self.close()
        self.trace.append(("cut", b""))
        return PortError(f"{self.url}: the connection was lost (fault)")

    def write(self, data: bytes) -> None:
        if not self.is_open:
            raise self._closed_error()
        self.trace.append(("tx", bytes(data)))
        self.last_activity = self.clock.now
        self.written += len(data)
        self._tail(data)
        self._peer(self.injector.feed, bytes(data), self.clock.now)
        if self.injector.disconnect_requested:
            raise self._cut()

    def read(self, timeout: float) -> bytes:
        if not self.is_open:
            raise self._closed_error()
        clock = self.clock
        end = clock.now + max(timeout, 0.0)
        while True:
            data: bytes = self._peer(self.injector.output, clock.now)
            if self.injector.disconnect_requested:
                raise self._cut()
            if data:
                self.trace.append(("rx", data))
                self.last_activity = clock.now
                self.received += len(data)
                return data
            if clock.now >= end:
                return b""
            deadline = self.injector.next_deadline()
            wake = end if deadline is None else min(end, max(deadline, clock.now + 1e-4))
            clock.sleep(wake - clock.now)


# -- the exchanges ---------------------------------------------------------------------------
JOB = FileName("DEMO", "JOB")
LONG_JOB = FileName("LONG", "JOB")
UPLOAD = FileName("UP", "JOB")
LONG_LINES = ("MAIN", *(f"DELAY {10 * i}" for i in range(1, 39)), "EOP")
UPLOAD_LINES = ("MAIN", *(f"OUT 0,{i % 16},{i % 2}" for i in range(1, 19)), "EOP")
GLOBAL_POINT = Point((10.0, 20.0, 30.0, 40.0, 0.0, 0.0), ArmForm.NONE, True)


def _prepared(sim: VirtualController) -> None:
    """A controller as a line would be found: origin done, a long job and two alarms stored."""
    ch = sim.model.channel(1)
    ch.origin = True
    ch.files.put(StoredJob(LONG_JOB, 7, list(LONG_LINES)))


def _with_alarms(sim: VirtualController) -> None:
    _prepared(sim)
    for code, channel in ((1153, 1), (9002, 2), (9005, 1)):
        sim.model.raise_alarm(code, channel, "matrix")


def _servo_off(sim: VirtualController) -> None:
    _prepared(sim)
    sim.model.channel(1).servo = False


def _job_selected(sim: VirtualController) -> None:
    _prepared(sim)
    _, finish = sim.model.select_job(1, JOB)
    finish()


def _motion_state(sim: VirtualController) -> Any:
    sim.model.advance(1000.0)  # let a started motion end, so a move counts once
    return tuple(round(v, 3) for v in sim.model.channel(1).joints)


def _file_state(sim: VirtualController) -> Any:
    stored = sim.model.channel(1).files.get(UPLOAD)
    return tuple(stored.lines) if isinstance(stored, StoredJob) else stored


def _no_state(sim: VirtualController) -> Any:
    return None


@dataclass(frozen=True)
class Case:
    """One exchange of the matrix: how to prepare the controller, the command, what to watch."""

    name: str
    command: Command[Any]
    prepare: Callable[[VirtualController], None] = _prepared
    observe: Callable[[VirtualController], Any] = _no_state


CASES: tuple[Case, ...] = (
    Case("AA", ReadStatus()),
    Case("AB", ReadAlarms(), _with_alarms),
    Case("DB", Servo(1, True), _servo_off, lambda sim: sim.model.channel(1).servo),
    Case("FA", DownloadFile(1, LONG_JOB)),
    Case("FB", UploadFile(1, UPLOAD, 9, UPLOAD_LINES), observe=_file_state),
    Case(
        "BD",
        MoveBy(1, MotionType.JOINT, CoordSystem.ANGLE, (5.0, 0.0, 0.0, 0.0)),
        observe=_motion_state,
    ),
    # A started job ends on its own, so CC is judged by its execution count alone.
    Case("CC", StartJob(1), _job_selected),
    Case(
        "GW",
        WriteGlobalPoint(1, 45, GLOBAL_POINT),
        observe=lambda sim: sim.model.channel(1).points.get(45),
    ),
)
"""Single (AA, BD, CC, GW), multi-packet (AB, FA of a 40-step job), two-phase (DB), upload
(FB)."""


# -- the faults ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Fault:
    """A fault of the matrix: an injector kind with its count (NAKs in a row) or hold."""

    name: str
    kind: FaultKind
    count: int = 1
    delay: bool = False
    latency: bool = False
    """Hold every answer packet from this one on, jittered up to 0.8 of the controller's
    resend time."""

    @property
    def per_packet(self) -> bool:
        """Fires on whole packets: a NAK storm on the host's, a repeat or latency on answers."""
        return self.kind in (FaultKind.NAK_STORM, FaultKind.REPEAT, FaultKind.LATENCY)

    @property
    def packets_of(self) -> Direction:
        return Direction.TO_CONTROLLER if self.kind is FaultKind.NAK_STORM else Direction.TO_HOST


FAULTS: tuple[Fault, ...] = (
    Fault("corrupt", FaultKind.CORRUPT),
    Fault("drop", FaultKind.DROP),
    Fault("duplicate", FaultKind.DUPLICATE),
    Fault("delay", FaultKind.DELAY, delay=True),
    Fault("NAK x1", FaultKind.NAK_STORM, 1),
    Fault("NAK x2", FaultKind.NAK_STORM, 2),
    Fault("NAK x3", FaultKind.NAK_STORM, 3),
    Fault("RST", FaultKind.RST),
    Fault("disconnect", FaultKind.DISCONNECT),
    Fault("repeat", FaultKind.REPEAT),
    Fault("latency", FaultKind.LATENCY, count=100_000, latency=True),
)
DIRECTIONS = (Direction.TO_CONTROLLER, Direction.TO_HOST)


@dataclass(frozen=True)
class MatrixConfig:
    """Timers of a matrix run. The controller resends an unACKed answer after ``ack_timeout``
    (up to 3 times), well inside the client's ``timeout``, so both recovery paths are met."""

    timeout: float = 1.0
    ack_timeout: float = 0.3
    retries: int = 1
    speedup: float = 50.0
    delay_factor: float = 1.5
    """A delay fault holds the bytes for this many client timeouts."""
    virtual: bool = True
    """Run on the virtual clock (False: real time, for a check that the two agree)."""


# -- running one cell ------------------------------------------------------------------------
@dataclass
class Trial:
    """One run of a case on a fresh controller and client."""

    case: Case
    config: MatrixConfig
    seed: int = 0
    """Seeds the injector's random choices (a corrupt fault's bit mask)."""

    def __post_init__(self) -> None:
        cfg = self.config
        self.clock = VirtualClock() if cfg.virtual else RealClock()
        self.sim = VirtualController(SimConfig(speedup=cfg.speedup, ack_timeout=cfg.ack_timeout))
        self.case.prepare(self.sim)
        self.injector = FaultInjector(self.sim, seed=self.seed)
        self.line = FaultLine(self.injector, self.clock)
        self.client = Client(
            self.line,
            timeout=cfg.timeout,
            retries=cfg.retries,
            reconnect=True,
            controller_timeout=cfg.ack_timeout,
        )

    def call(self, command: Command[Any]) -> Any:
        return self.client.execute(command)


@dataclass(frozen=True)
class Baseline:
    """A case run without a fault: what every faulted run of it is judged against."""

    result: Any
    before: Any
    after: Any
    executions: int
    tx: int
    rx: int
    host_packets: tuple[int, ...]
    """Byte positions (to_controller) where the host's packets start."""
    answer_packets: tuple[int, ...]
    """Byte positions (to_host) where the controller's packets start."""
    wait: float
    """Seconds a two-phase answer announces (the host waits that much longer)."""


@functools.lru_cache(maxsize=64)
def baseline(case: Case, config: MatrixConfig) -> Baseline:
    """The case without a fault: its result, the state before and after, its byte counts."""
    trial = Trial(case, config)
    with virtual_time(trial.clock):
        before = case.observe(trial.sim)
        trial.clock.arm(120.0)
        result = trial.call(case.command)
        tx, rx = trial.line.written, trial.line.received
        stream = b"".join(data for way, data in trial.line.trace if way == "tx")
        starts = tuple(i for i, byte in enumerate(stream) if byte == STX)
        answers = b"".join(data for way, data in trial.line.trace if way == "rx")
        answer_starts = tuple(i for i, byte in enumerate(answers) if byte == STX)
        after = case.observe(trial.sim)
    wait = float(result) if case.command.SHAPE is Shape.TWO_PHASE and result else 0.0
    executions = trial.sim.executions[case.command.CODE]
    return Baseline(result, before, after, executions, tx, rx, starts, answer_starts, wait)


@dataclass(frozen=True)
class CellResult:
    case: str
    fault: str
    direction: str
    position: int
    outcome: str
    """``ok``, ``error:<Class>`` (``+executed`` when a state-changing command ran anyway), or
    ``VIOLATION:<what>``."""
    seconds: float
    """Virtual seconds the faulted call took."""
    quiet: float
    """Virtual seconds between the line's last movement and the error (0 when it completed)."""
    detail: str = ""
    trace: tuple[tuple[str, str], ...] = ()

    @property
    def violation(self) -> bool:
        return self.outcome.startswith("VIOLATION")

    @property
    def verdict(self) -> str:
        """``ok``, ``typed error``, ``violation`` or ``not reached``."""
        if self.violation:
            return "violation"
        return self.outcome if self.outcome in ("ok", "not reached") else "typed error"


def _label_error(case: Case, error: RobostarError, executions: int) -> str:
    label = f"error:{type(error).__name__}"
    if (
        case.command.CHANGES_STATE
        and executions
        and not isinstance(error, OutcomeUnknownError | UploadIncompleteError)
    ):
        label += "+executed"
    return label


def run_cell(
    case: Case,
    fault: Fault,
    direction: Direction,
    position: int,
    config: MatrixConfig,
    base: Baseline,
) -> CellResult:
    """Run one cell and judge it (see the module docstring)."""
    seed = zlib.crc32(f"{case.name}/{fault.name}/{direction.value}/{position}".encode())
    trial = Trial(case, config, seed)
    seconds = quiet = 0.0
    detail = ""
    with virtual_time(trial.clock):
        if fault.latency:
            trial.injector.add(
                FaultSpec(
                    fault.kind,
                    direction,
                    at_byte=position,
                    count=fault.count,
                    # A slow controller: up to 0.8 of its own resend time (beyond it, a
                    # controller whose timer is that short resends every packet).
                    seconds=0.8 * config.ack_timeout,
                    low=0.1 * config.ack_timeout,
                )
            )
        else:
            trial.injector.schedule(
                fault.kind,
                direction,
                at_byte=position,
                count=fault.count,
                seconds=config.timeout * config.delay_factor if fault.delay else 0.0,
            )
        start = trial.clock.now
        trial.clock.arm(300.0)
        error: RobostarError | None = None
        result: Any = None
        try:
            result = trial.call(case.command)
        except RobostarError as exc:
            error = exc
        except Hang as exc:
            outcome = "VIOLATION:hang"
            return _result(case, fault, direction, position, outcome, 0, 0, str(exc), trial)
        except SimulatorCrash as exc:
            outcome = "VIOLATION:simulator crashed"
            return _result(case, fault, direction, position, outcome, 0, 0, str(exc), trial)
        except Exception as exc:
            outcome = f"VIOLATION:untyped {type(exc).__name__}"
            return _result(case, fault, direction, position, outcome, 0, 0, repr(exc), trial)
        seconds = trial.clock.now - start
        fired = trial.injector.total() > 0
        trial.injector.clear()
        executions = trial.sim.executions[case.command.CODE]
        if error is None:
            outcome = "ok"
            state = case.observe(trial.sim)
            if result != base.result:
                outcome, detail = "VIOLATION:wrong result", f"{result!r} != {base.result!r}"
            elif case.command.CHANGES_STATE and executions != 1:
                outcome, detail = "VIOLATION:executed", f"{executions} times"
            elif state != base.after:
                outcome, detail = "VIOLATION:state", f"{state!r} != {base.after!r}"
        else:
            quiet = trial.clock.now - trial.line.last_activity
            outcome = _label_error(case, error, executions)
            detail = str(error)
            if executions > 1:
                outcome = "VIOLATION:executed twice"
            elif quiet > config.timeout + base.wait + 1e-6:
                outcome = "VIOLATION:slow error"
        if not fired and not outcome.startswith("VIOLATION"):
            outcome = "not reached"
        if not outcome.startswith("VIOLATION"):
            outcome, detail = _after_checks(trial, case, base, error, outcome, detail)
    return _result(case, fault, direction, position, outcome, seconds, quiet, detail, trial)


def _after_checks(
    trial: Trial, case: Case, base: Baseline, error: BaseException | None, outcome: str, detail: str
) -> tuple[str, str]:
    """The next normal exchange works; a state-changing command's state is consistent; an
    upload the caller believes complete reads back whole."""
    trial.clock.arm(60.0)
    try:
        trial.call(ReadStatus())
    except SimulatorCrash as exc:
        return "VIOLATION:simulator crashed", f"{detail} / next AA: {exc}"
    except (RobostarError, Hang) as exc:
        return "VIOLATION:next exchange failed", f"{detail} / next AA: {exc!r}"
    if error is not None and case.command.CHANGES_STATE:
        state = case.observe(trial.sim)
        if state not in (base.before, base.after):
            return "VIOLATION:state", f"{detail} / state {state!r}"
    if error is None and isinstance(case.command, UploadFile):
        try:
            back = trial.call(DownloadFile(1, UPLOAD))
        except (RobostarError, Hang, SimulatorCrash) as exc:
            return "VIOLATION:upload not complete", f"FA readback failed: {exc!r}"
        if not isinstance(back, JobFile) or back.lines != UPLOAD_LINES:
            return "VIOLATION:upload not complete", f"read back {back!r}"
    return outcome, detail


def _result(
    case: Case,
    fault: Fault,
    direction: Direction,
    position: int,
    outcome: str,
    seconds: float,
    quiet: float,
    detail: str,
    trial: Trial,
) -> CellResult:
    trace: tuple[tuple[str, str], ...] = ()
    if outcome.startswith("VIOLATION"):
        trace = tuple((way, data.hex(" ")) for way, data in trial.line.trace)
    return CellResult(
        case.name,
        fault.name,
        direction.value,
        position,
        outcome,
        round(seconds, 4),
        round(quiet, 4),
        detail[:500],
        trace,
    )


# -- scenario rows ---------------------------------------------------------------------------
class ScriptedLine(FaultLine):
    """The matrix's line with two misbehaviours of its own, each armed by a scenario:

    - ``resend_forever``: the host's ACKs never reach the controller, and whenever the
      controller has been silent for that long the line sends its last answer packet again
      (a controller that resends without end, past the manual's three resends);
    - ``hold``: the controller's next bytes are held this long, and what follows them waits
      behind (a device server that held one answer past the client's timeout and quiet
      gap)."""

    def __init__(self, injector: FaultInjector, clock: VirtualClock) -> None:
        super().__init__(injector, clock)
        self.resend_forever: float | None = None
        self.hold = 0.0
        self.replayed = 0
        self._replay_at: float | None = None
        self._later: list[tuple[float, bytes]] = []
        self._answers = FrameDecoder()
        self._last_answer = b""

    def write(self, data: bytes) -> None:
        if self.resend_forever is not None and ACK in data:
            data = data.replace(bytes((ACK,)), b"")  # no packet byte is ever an ACK
            if not data:
                self.trace.append(("tx swallowed", bytes((ACK,))))
                return
        super().write(data)

    def read(self, timeout: float) -> bytes:
        if not self.is_open:
            raise self._closed_error()
        clock = self.clock
        end = clock.now + max(timeout, 0.0)
        while True:
            data: bytes = self._peer(self.injector.output, clock.now)
            if data and (self.hold or self._later):
                # held, or behind what is held: a line delivers in order
                last = self._later[-1][0] if self._later else 0.0
                self._later.append((max(clock.now + self.hold, last), data))
                self.hold = 0.0
                data = b""
            due = [chunk for at, chunk in self._later if at <= clock.now]
            if due:
                self._later = [(at, chunk) for at, chunk in self._later if at > clock.now]
                data = b"".join(due)
            period = self.resend_forever
            if period is not None and self._last_answer:
                if data:
                    self._replay_at = clock.now + period
                elif self._replay_at is not None and clock.now >= self._replay_at:
                    data = self._last_answer
                    self.replayed += 1
                    self._replay_at = clock.now + period
            if data:
                for event in self._answers.feed(data):
                    if isinstance(event, Packet):
                        self._last_answer = encode_packet(event.data)
                self.trace.append(("rx", data))
                self.last_activity = clock.now
                self.received += len(data)
                return data
            if clock.now >= end:
                return b""
            times = [t for t in (self.injector.next_deadline(), end) if t is not None]
            times += [at for at, _ in self._later]
            if self.resend_forever is not None and self._replay_at is not None:
                times.append(self._replay_at)
            clock.sleep(max(min(times), clock.now + 1e-4) - clock.now)


G10, G20 = 1010, 2020


def _globals_set(sim: VirtualController) -> None:
    _prepared(sim)
    sim.model.ints[10], sim.model.ints[20] = G10, G20


@dataclass(frozen=True)
class Scenario:
    """A matrix row that is not a fault at a byte position: a misbehaviour of the line over a
    whole call (``ScriptedLine``), judged by ``run_scenario``."""

    name: str
    cases: tuple[Case, ...]


RESEND_FOREVER = Scenario(
    "resend beyond the limit",
    tuple(c for c in CASES if c.name in ("AA", "AB", "FA", "DB")),
)
LATENCY_AFTER_ABORT = Scenario(
    "latency after abort",
    (Case("GR", ReadGlobalInt(10), _globals_set),),
)
SCENARIOS = (RESEND_FOREVER, LATENCY_AFTER_ABORT)
"""The scenario rows: a controller resending past the manual's limit (each case's call ends,
with its answer or a typed error — LinkRuleError for a multi-packet answer — and the line is
clean for the next call), and an answer held past the client's timeout and quiet gap (the
call given up; the next read, of another global, must get its own value, never the given-up
read's)."""


def run_scenario(scenario: Scenario, case: Case, config: MatrixConfig) -> CellResult:
    """Run one scenario row's case and judge it (as a cell: no hang, a typed error or the
    unfaulted result, and the next exchange right)."""
    trial = Trial(case, config)
    line = ScriptedLine(trial.injector, trial.clock)
    trial.line = line
    trial.client = Client(
        line,
        timeout=config.timeout,
        # the given-up read is not asked again: its late answer meets the next read
        retries=0 if scenario is LATENCY_AFTER_ABORT else config.retries,
        reconnect=True,
        controller_timeout=config.ack_timeout,
    )
    fault = Fault(scenario.name, FaultKind.REPEAT)
    direction = Direction.TO_HOST
    base = baseline(case, config)
    with virtual_time(trial.clock):
        if scenario is RESEND_FOREVER:
            line.resend_forever = config.ack_timeout
        else:
            # past the timeout and the quiet gap after the RST (one timeout each): it comes
            # while the next read waits for its answer
            line.hold = 2.2 * config.timeout
        start = trial.clock.now
        trial.clock.arm(300.0)
        error: RobostarError | None = None
        result: Any = None
        try:
            result = trial.call(case.command)
        except RobostarError as exc:
            error = exc
        except Hang as exc:
            return _result(case, fault, direction, 0, "VIOLATION:hang", 0, 0, str(exc), trial)
        seconds = trial.clock.now - start
        line.resend_forever = None
        detail = "" if error is None else str(error)
        if error is None:
            outcome = "ok"
            if result != base.result:
                outcome, detail = "VIOLATION:wrong result", f"{result!r} != {base.result!r}"
        else:
            outcome = _label_error(case, error, trial.sim.executions[case.command.CODE])
        multi = case.command.SHAPE is Shape.MULTI
        if scenario is RESEND_FOREVER and multi and not isinstance(error, LinkRuleError):
            outcome = "VIOLATION:copies beyond the limit taken"
        if scenario is LATENCY_AFTER_ABORT:
            if error is None:
                outcome = "VIOLATION:not given up"
            trial.clock.arm(60.0)
            try:
                value = trial.call(ReadGlobalInt(20))
            except (RobostarError, Hang) as exc:
                return _result(
                    case,
                    fault,
                    direction,
                    0,
                    "VIOLATION:next read failed",
                    seconds,
                    0,
                    repr(exc),
                    trial,
                )
            if value != G20:
                return _result(
                    case,
                    fault,
                    direction,
                    0,
                    "VIOLATION:old answer taken",
                    seconds,
                    0,
                    f"g20 read {value}",
                    trial,
                )
        if not outcome.startswith("VIOLATION"):
            outcome, detail = _after_checks(trial, case, base, error, outcome, detail)
    return _result(case, fault, direction, 0, outcome, seconds, 0.0, detail, trial)


def run_scenarios(scenarios: Sequence[Scenario] = SCENARIOS) -> list[CellResult]:
    """Every scenario row, as cells (one per case)."""
    config = MatrixConfig()
    return [run_scenario(s, case, config) for s in scenarios for case in s.cases]


# -- the whole matrix ------------------------------------------------------------------------
def positions(fault: Fault, direction: Direction, base: Baseline) -> Sequence[int]:
    """Every byte position of the exchange in that direction; for a fault on whole packets (a
    NAK storm answers a host packet; a repeat or a latency comes before an answer packet) the
    first byte of every packet it can hit."""
    if fault.per_packet:
        if direction is not fault.packets_of:
            return ()
        return base.host_packets if direction is Direction.TO_CONTROLLER else base.answer_packets
    return range(base.tx if direction is Direction.TO_CONTROLLER else base.rx)


CI_STRIDE = {"FA": 9, "FB": 6}
"""The CI slice takes every n-th byte position of the two long exchanges (offset per fault, so
that together the faults still touch every position); all positions of the others."""


def row(
    case: Case, fault: Fault, direction: Direction, config: MatrixConfig, stride: int = 1
) -> list[int]:
    """The positions of one matrix row (every ``stride``-th one, offset by the fault; a NAK
    storm's few packet positions are never thinned)."""
    if fault.per_packet:
        stride = 1
    offset = FAULTS.index(fault) % stride if fault in FAULTS else 0
    return [p for p in positions(fault, direction, baseline(case, config)) if p % stride == offset]


def run_row(
    case: Case, fault: Fault, direction: Direction, config: MatrixConfig, stride: int = 1
) -> list[CellResult]:
    base = baseline(case, config)
    return [
        run_cell(case, fault, direction, p, config, base)
        for p in row(case, fault, direction, config, stride)
    ]


def rows(cases: Sequence[Case] = CASES) -> Iterator[tuple[Case, Fault, Direction]]:
    """Every (exchange, fault, direction) that has cells (a NAK storm only answers the host; a
    repeat and a latency only touch answers)."""
    for case, fault, direction in itertools.product(cases, FAULTS, DIRECTIONS):
        if not fault.per_packet or direction is fault.packets_of:
            yield case, fault, direction


def _examples(results: Sequence[CellResult], per_row: int) -> list[CellResult]:
    """The first few results of each (exchange, fault, direction) row."""
    seen: Counter[tuple[str, str, str]] = Counter()
    kept = []
    for r in results:
        key = (r.case, r.fault, r.direction)
        seen[key] += 1
        if seen[key] <= per_row:
            kept.append(r)
    return kept


def summarise(results: Sequence[CellResult], wall: float) -> dict[str, Any]:
    """The matrix as counts per (exchange, fault, direction), with up to five violating cells
    of each row in full (outcome, detail, byte trace)."""
    table: dict[str, dict[str, dict[str, Counter[str]]]] = {}
    worst: dict[str, float] = {}
    for r in results:
        row = table.setdefault(r.case, {}).setdefault(r.fault, {})
        row.setdefault(r.direction, Counter())[r.outcome] += 1
        worst[r.case] = max(worst.get(r.case, 0.0), r.seconds)
    violations = [r for r in results if r.violation]
    totals = Counter(r.verdict for r in results)
    return {
        "cells": len(results),
        "totals": dict(totals),
        "violations": len(violations),
        "violations_by_kind": dict(Counter(r.outcome for r in violations).most_common()),
        "wall_seconds": round(wall, 1),
        "longest_call_virtual_seconds": {k: round(v, 3) for k, v in worst.items()},
        "table": {
            case: {
                fault: {d: dict(c.most_common()) for d, c in dirs.items()}
                for fault, dirs in row.items()
            }
            for case, row in table.items()
        },
        "violation_cells": [r.__dict__ for r in _examples(violations, 5)],
    }


def run_matrix(
    config: MatrixConfig,
    cases: Sequence[Case] = CASES,
    strides: dict[str, int] | None = None,
    progress: Callable[[int], None] | None = None,
) -> tuple[list[CellResult], float]:
    """Run every row (``strides``: case name -> stride; default all positions); returns the
    results and the wall-clock seconds taken."""
    start = time.perf_counter()
    results: list[CellResult] = []
    for case, fault, direction in rows(cases):
        stride = (strides or {}).get(case.name, 1)
        results += run_row(case, fault, direction, config, stride)
        if progress is not None:
            progress(len(results))
    for scenario in SCENARIOS:
        results += [run_scenario(scenario, case, config) for case in scenario.cases]
    return results, time.perf_counter() - start
