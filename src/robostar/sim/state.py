"""The simulator's state: channels, time, status, alarms and deferred work (the model's base).

:class:`ModelBase` holds the channels (servo, origin, position, motion, jog, files, job), the I/O
contacts, the global variables, the alarms and the KD text, and moves model time on
(:meth:`ModelBase.advance`): motion, homing, jobs and deferred actions. The operations the
commands call are added by the ``ops_*`` modules; :class:`robostar.sim.model.Model` puts it
together.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from robostar.protocol.fields import FLAG_FAILED, FileName
from robostar.sim.alarms import ALL_CHANNELS, EMERGENCIES, AlarmCode, AlarmEntry, AlarmLog
from robostar.sim.config import ChannelConfig, SimConfig
from robostar.sim.filesystem import ChannelFiles, default_files
from robostar.sim.jobs import JobRunner
from robostar.sim.kinematics import Unreachable, arm_of, limit_problem, to_joints, to_pulses, to_xy
from robostar.sim.motion import (
    Path,
)
from robostar.sim.parameters import public_parameters
from robostar.types import (
    ArmForm,
    ChannelStatus,
    JobMode,
    Point,
    Position,
    PositionKind,
)

__all__ = ["Channel", "Jog", "ModelBase", "Refused", "Timer"]

Joints = tuple[float, ...]

DEFAULT_SPEED = 300
PORTS = 5
CONTACTS = 16
_EPS = 1e-9


class Refused(Exception):
    """A request the controller will not carry out: the answer ``flag`` and KD's ``reason``."""

    def __init__(self, reason: str, flag: int = FLAG_FAILED):
        self.flag = flag
        self.reason = reason
        super().__init__(reason)


@dataclass
class Timer:
    """A deferred action (a two-phase command's work); ``failure`` is set if it could not be
    done when its time came."""

    at: float
    action: Callable[[], None]
    done: bool = False
    failure: Refused | None = None


@dataclass
class Jog:
    """A jog in progress: one axis (1-based), in joint space or along an XY axis."""

    axis: int
    sign: float
    linear: bool
    speed: float
    start: Joints
    start_xy: Joints
    arm: ArmForm
    elapsed: float = 0.0
    stalled: bool = False


class Channel:
    """One robot channel's state."""

    def __init__(self, number: int, cfg: ChannelConfig):
        self.number = number
        self.cfg = cfg
        self.files: ChannelFiles = default_files(cfg)
        self.speed = DEFAULT_SPEED
        self.points: dict[int, Point] = {}
        self.job: JobRunner | None = None
        self.job_name: FileName | None = None
        self.joints: Joints = tuple(min(max(0.0, lo), hi) for lo, hi in cfg.limits)
        self.reset_volatile()

    def reset_volatile(self) -> None:
        """Power-on state of everything a restart loses (the robot stays where it is)."""
        self.servo = False
        self.origin = False
        self.path: Path | None = None
        self.path_t = 0.0
        self.homing = False
        self.jog: Jog | None = None
        self.mode = JobMode.AUTO
        self.reference_axis = 1
        if self.job is not None:
            self.job.reset()

    @property
    def moving(self) -> bool:
        return self.path is not None or self.jog is not None

    @property
    def running(self) -> bool:
        """AA's RUN bit: a job runs or the robot moves."""
        return self.moving or (self.job is not None and self.job.running)

    @property
    def arm(self) -> ArmForm:
        return arm_of(self.cfg, self.joints)

    def stop_motion(self) -> None:
        self.path = None
        self.homing = False
        self.jog = None

    def halt(self) -> None:
        """Stop the robot and hold the job."""
        self.stop_motion()
        if self.job is not None:
            self.job.hold()

    def next_event(self, now: float) -> float | None:
        times = []
        if self.path is not None:
            times.append(now + max(0.0, self.path.duration - self.path_t))
        if self.job is not None:
            job_time = self.job.next_event(now)
            if job_time is not None:
                times.append(job_time)
        return min(times, default=None)

    def move_on(self, dt: float) -> None:
        """Advance motion by ``dt`` model seconds."""
        if self.path is not None:
            self.path_t += dt
            self.joints = self.path.at(self.path_t)
            if self.path_t >= self.path.duration - _EPS:
                if self.homing:
                    self.origin = True
                self.path = None
                self.homing = False
        if self.jog is not None and not self.jog.stalled and dt > 0:
            self.jog.elapsed += dt
            self.joints = self._jog_position(self.jog)

    def _jog_at(self, jog: Jog, t: float) -> Joints | None:
        """Joint values ``t`` seconds into a jog, or None where the jog cannot go."""
        if jog.linear:
            xy = list(jog.start_xy)
            xy[jog.axis - 1] += jog.sign * jog.speed * t
            try:
                joints = to_joints(self.cfg, xy, jog.arm)
            except Unreachable:
                return None
        else:
            values = list(jog.start)
            values[jog.axis - 1] += jog.sign * jog.speed * t
            joints = tuple(values)
        if limit_problem(self.cfg, joints) is not None or arm_of(self.cfg, joints) is not jog.arm:
            return None
        return joints

    def _jog_position(self, jog: Jog) -> Joints:
        joints = self._jog_at(jog, jog.elapsed)
        if joints is not None:
            return joints
        # Find where the jog hit its limit and stay there.
        lo, hi = 0.0, jog.elapsed
        for _ in range(40):
            mid = (lo + hi) / 2
            if self._jog_at(jog, mid) is None:
                hi = mid
            else:
                lo = mid
        jog.elapsed = lo
        jog.stalled = True
        return self._jog_at(jog, lo) or self.joints


class ModelBase:
    """The state every operation works on. Model time (``clock``, the work timer) is in seconds."""

    def __init__(self, config: SimConfig | None = None):
        self.config = config or SimConfig()
        self.clock = 0.0
        self.channels = [Channel(i + 1, cfg) for i, cfg in enumerate(self.config.channels)]
        self.alarms = AlarmLog()
        self.inputs = [[False] * CONTACTS for _ in range(PORTS)]
        self.outputs = [[False] * CONTACTS for _ in range(PORTS)]
        self.ints: dict[int, int] = {}
        self.floats: dict[int, float] = {}
        self.last_error = "no error"
        self.revision = 0
        """Bumped by every change to the state a snapshot keeps."""
        self.public_parameters = public_parameters(self.config)
        self._timers: list[Timer] = []

    # -- bookkeeping ---------------------------------------------------------------------------
    def changed(self) -> None:
        self.revision += 1

    def channel(self, number: int) -> Channel:
        """A configured channel, or Refused (0x32) beyond MAX CH."""
        if not 1 <= number <= len(self.channels):
            raise Refused(f"channel {number} is not configured (MAX CH is {len(self.channels)})")
        return self.channels[number - 1]

    def schedule(self, delay: float, action: Callable[[], None]) -> Timer:
        """Run ``action`` after ``delay`` model seconds; it may raise Refused."""
        timer = Timer(self.clock + delay, action)
        self._timers.append(timer)
        return timer

    # -- time ----------------------------------------------------------------------------------
    def next_event(self) -> float | None:
        """Model time of the next thing that happens by itself (None: nothing scheduled)."""
        times = [t.at for t in self._timers]
        for ch in self.channels:
            event = ch.next_event(self.clock)
            if event is not None:
                times.append(event)
        return min(times, default=None)

    def advance(self, dt: float) -> None:
        """Move model time on by ``dt`` seconds, stopping at every event on the way."""
        end = self.clock + max(0.0, dt)
        if not self._timers and all(
            ch.path is None and ch.jog is None and ch.job is None for ch in self.channels
        ):
            # Nothing moves, runs or is scheduled (the usual poll of an idle cell): only the
            # clock goes on, without the event search below.
            self.clock = end
            return
        while True:
            self._tick_jobs()
            target = end
            event = self.next_event()
            # An event a rounding error past the end is due now, or a driver that computed
            # its deadline from it would call again and again without reaching it.
            if event is not None and event <= end + _EPS:
                target = max(event, self.clock)
            step = target - self.clock
            for ch in self.channels:
                ch.move_on(step)
            self.clock = target
            self._run_timers()
            if target >= end:
                self._tick_jobs()
                return

    def _tick_jobs(self) -> None:
        """Step the running jobs at this instant (the job operations fill this in)."""

    def io_ports(self, output: bool) -> int:
        """The highest I/O port that exists: port 0 is the main board's, each board adds two."""
        return 2 * self.config.io_boards[1 if output else 0]

    def _run_timers(self) -> None:
        due = [t for t in self._timers if t.at <= self.clock + _EPS]
        if not due:
            return
        self._timers = [t for t in self._timers if t.at > self.clock + _EPS]
        for timer in due:
            try:
                timer.action()
            except Refused as exc:
                timer.failure = exc
            timer.done = True

    # -- status and position -------------------------------------------------------------------
    def status(self) -> tuple[ChannelStatus, ChannelStatus, ChannelStatus]:
        # Through the status byte: ChannelStatus.from_byte hands out the instances made once.
        bits = [0, 0, 0]
        for ch in self.channels:
            alarm = self.alarms.on_channel(ch.number)
            bits[ch.number - 1] = (
                (0x20 if ch.servo else 0)
                | (0x10 if ch.origin else 0)
                | (0x08 if alarm else 0)
                | (0 if alarm else 0x04)
                | (0x02 if ch.servo and not ch.moving else 0)
                | (0x01 if ch.running else 0)
            )
        from_byte = ChannelStatus.from_byte
        return from_byte(bits[0]), from_byte(bits[1]), from_byte(bits[2])

    def position(self, number: int, kind: PositionKind) -> Position:
        ch = self.channel(number)
        if kind is PositionKind.PULSE:
            return Position(kind, tuple(float(p) for p in to_pulses(ch.cfg, ch.joints)))
        if kind is PositionKind.ANGLE:
            return Position(kind, ch.joints)
        return Position(kind, to_xy(ch.cfg, ch.joints), ch.arm)

    # -- alarms --------------------------------------------------------------------------------
    def raise_alarm(self, code: int, channel: int = ALL_CHANNELS, detail: str = "") -> AlarmEntry:
        """Raise an alarm (test hook too): the channel(s) stop; emergencies turn the servo off."""
        entry = self.alarms.raise_alarm(code, channel, self.clock, detail)
        for ch in self.channels:
            if channel in (ch.number, ALL_CHANNELS):
                ch.halt()
                if code in EMERGENCIES:
                    ch.servo = False
        self.changed()
        return entry

    def _alarm_refusal(self, code: AlarmCode, ch: Channel, reason: str, detail: str) -> Refused:
        self.raise_alarm(code, ch.number, detail)
        return Refused(reason)

    def emergency_stop(self) -> None:
        self.raise_alarm(AlarmCode.HOST_EMERGENCY, ALL_CHANNELS, "CF")

    def reset_alarms(self) -> None:
        self.alarms.clear()

    def restart(self) -> None:
        """CJ: volatile state back to power-on; files, globals, outputs and history stay."""
        on = [ch.number for ch in self.channels if ch.servo]
        if on:
            raise Refused(f"servo is on (channel {on[0]}); CJ needs every servo off")
        for timer in self._timers:
            timer.failure = Refused("the controller restarted")
            timer.done = True
        self._timers.clear()
        self.alarms.clear()
        for ch in self.channels:
            ch.reset_volatile()
        self.last_error = "no error"
