"""Motion operations: homing, moves (BB, BC, BD), jog, servo, speed and the reference axis."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from robostar.protocol.fields import FLAG_UNSUPPORTED, FileName
from robostar.sim.alarms import AlarmCode
from robostar.sim.filesystem import StoredPoints
from robostar.sim.kinematics import Unreachable, to_joints, to_xy
from robostar.sim.motion import (
    Path,
    PathError,
    PathProblem,
    plan_arc,
    plan_circle,
    plan_homing,
    plan_joint,
    plan_linear,
)
from robostar.sim.state import (
    Channel,
    Jog,
    Joints,
    ModelBase,
    Refused,
)
from robostar.types import (
    CoordSystem,
    JogDirection,
    MotionType,
    RobotType,
)

__all__ = ["MotionOps"]

SERVO_ON_TIME = 0.3
SERVO_OFF_TIME = 0.1
_PATH_ALARMS = {
    PathProblem.LIMIT: AlarmCode.SOFT_LIMIT,
    PathProblem.REACH: AlarmCode.OUT_OF_REACH,
    PathProblem.SHAPE: AlarmCode.PATH_ERROR,
}


class MotionOps(ModelBase):
    """BA, BB, BC, BD, BE-BG, CI, DB, CB, CX: what moves the robot or readies it."""

    # -- motion --------------------------------------------------------------------------------
    def _check_motion(self, ch: Channel, code: str, *, needs_origin: bool) -> None:
        """The rules every motion command keeps, in the order a controller meets them."""
        if not ch.cfg.can_move:
            raise Refused(
                f"channel {ch.number} is a {ch.cfg.robot.name} channel with no robot",
                FLAG_UNSUPPORTED,
            )
        if self.alarms.on_channel(ch.number):
            raise Refused(f"channel {ch.number} has an alarm; reset it with CG first")
        if ch.running:
            raise Refused(f"channel {ch.number} is busy (moving or running a job)")
        if needs_origin and not ch.origin:
            raise self._alarm_refusal(
                AlarmCode.RUN_FAIL,
                ch,
                f"origin return (BA) is not done on channel {ch.number}",
                f"{code} no origin",
            )
        if not ch.servo and not self.config.auto_servo_on:
            raise Refused(
                f"servo off on channel {ch.number}: AUTO SERVO ON is DIS, turn it on with DB first"
            )
        if ch.speed == 0 and code != "BA":
            raise Refused(f"speed is 0 on channel {ch.number}; set a speed with CB")

    def _start(self, ch: Channel, path: Path, *, homing: bool = False) -> None:
        ch.servo = True
        ch.path = path
        ch.path_t = 0.0
        ch.homing = homing

    def _targets(
        self, ch: Channel, values: Sequence[Sequence[float]], coords: CoordSystem, code: str
    ) -> list[Joints]:
        """Request coordinates as joint values (XY through the inverse kinematics, in the
        robot's current arm form)."""
        out = []
        for point in values:
            joints = self._fit_axes(ch, point, code)
            if coords is CoordSystem.XY:
                try:
                    joints = to_joints(ch.cfg, joints, ch.arm)
                except Unreachable as exc:
                    raise self._alarm_refusal(AlarmCode.OUT_OF_REACH, ch, str(exc), code) from None
            out.append(joints)
        return out

    @staticmethod
    def _fit_axes(ch: Channel, values: Sequence[float], code: str) -> Joints:
        axes = ch.cfg.axes
        if len(values) < axes:
            raise Refused(
                f"{code}: channel {ch.number} has {axes} axes; {len(values)} value(s) were sent"
            )
        if any(v != 0 for v in values[axes:]):
            raise Refused(
                f"{code}: channel {ch.number} has {axes} axes; values for axes beyond are not 0"
            )
        return tuple(values[:axes])

    def _plan(self, ch: Channel, motion: MotionType, targets: list[Joints], code: str) -> Path:
        try:
            if motion is MotionType.JOINT:
                return plan_joint(ch.cfg, ch.joints, targets[0], ch.speed)
            if motion is MotionType.LINEAR:
                return plan_linear(ch.cfg, ch.joints, targets[0], ch.speed)
            if motion is MotionType.ARC:
                return plan_arc(ch.cfg, ch.joints, targets[0], targets[1], ch.speed)
            return plan_circle(ch.cfg, ch.joints, targets[0], targets[1], ch.speed)
        except PathError as exc:
            raise self._alarm_refusal(_PATH_ALARMS[exc.problem], ch, exc.message, code) from None

    def home(self, number: int) -> None:
        ch = self.channel(number)
        self._check_motion(ch, "BA", needs_origin=False)
        ch.origin = False
        self._start(ch, plan_homing(ch.cfg, ch.joints), homing=True)

    def stop_homing(self, number: int) -> None:
        ch = self.channel(number)
        if ch.homing:
            ch.stop_motion()
            if self.config.auto_servo_on:
                ch.servo = False

    def move(
        self,
        number: int,
        motion: MotionType,
        coords: CoordSystem,
        points: Sequence[Sequence[float]],
        code: str = "BC",
    ) -> None:
        """BC: to coordinates (one target, or via + target, or two vias)."""
        ch = self.channel(number)
        self._check_motion(ch, code, needs_origin=True)
        targets = self._targets(ch, points, coords, code)
        self._start(ch, self._plan(ch, motion, targets, code))

    def move_by(
        self, number: int, motion: MotionType, coords: CoordSystem, delta: Sequence[float]
    ) -> None:
        """BD: by a delta in joint values or XY from where the robot is."""
        ch = self.channel(number)
        self._check_motion(ch, "BD", needs_origin=True)
        step = self._fit_axes(ch, delta, "BD")
        here = ch.joints if coords is CoordSystem.ANGLE else to_xy(ch.cfg, ch.joints)
        target = tuple(a + b for a, b in zip(here, step, strict=True))
        targets = self._targets(ch, [target], coords, "BD")
        self._start(ch, self._plan(ch, motion, targets, "BD"))

    def _pnt_point(self, ch: Channel, file: FileName, number: int, code: str) -> Joints:
        """A PNT file's point as joint values, or run-fail alarm + Refused."""
        stored = ch.files.get(file)
        if not isinstance(stored, StoredPoints):
            raise self._alarm_refusal(
                AlarmCode.RUN_FAIL, ch, f"no file {file} on channel {ch.number}", f"{code} {file}"
            )
        point = stored.points.get(number)
        if point is None or not point.used:
            raise self._alarm_refusal(
                AlarmCode.RUN_FAIL,
                ch,
                f"point P{number} of {file} is not used",
                f"{code} P{number}",
            )
        values = list(point.axes[: ch.cfg.axes])
        values += ch.joints[len(values) :]
        return tuple(values)

    def move_to_point(
        self, number: int, file: FileName, motion: MotionType, point: int, point2: int
    ) -> None:
        """BB: to a PNT file's point (or via point to point2, or through both)."""
        ch = self.channel(number)
        self._check_motion(ch, "BB", needs_origin=True)
        numbers = [point] if motion in (MotionType.JOINT, MotionType.LINEAR) else [point, point2]
        targets = [self._pnt_point(ch, file, n, "BB") for n in numbers]
        self._start(ch, self._plan(ch, motion, targets, "BB"))

    # -- jog -----------------------------------------------------------------------------------
    def start_jog(
        self, number: int, axis: int, direction: JogDirection, motion: MotionType
    ) -> None:
        ch = self.channel(number)
        if ch.jog is not None and ch.path is None and not (ch.job and ch.job.running):
            ch.jog = None  # a new BE replaces the jog in progress
        self._check_motion(ch, "BE", needs_origin=False)
        if axis > ch.cfg.axes:
            raise Refused(f"axis {axis} is not used on channel {ch.number} ({ch.cfg.axes} axes)")
        factor = ch.speed / 1000.0
        linear = motion is MotionType.LINEAR and ch.cfg.robot is RobotType.SCARA and axis <= 4
        speed = (
            ch.cfg.linear_speed * factor
            if linear and axis <= 3
            else ch.cfg.max_speed[axis - 1] * factor
        )
        ch.servo = True
        ch.jog = Jog(
            axis,
            1.0 if direction is JogDirection.PLUS else -1.0,
            linear,
            speed,
            ch.joints,
            to_xy(ch.cfg, ch.joints),
            ch.arm,
        )

    def continue_jog(self, number: int) -> None:
        ch = self.channel(number)
        if ch.jog is None:
            raise Refused(f"no jog in progress on channel {ch.number} (start it with BE)")

    def stop_jog(self, number: int) -> None:
        self.channel(number).jog = None

    # -- servo ---------------------------------------------------------------------------------
    def servo(self, number: int, on: bool) -> tuple[float, Callable[[], None]]:
        """DB: how long it takes and the action that finishes it."""
        ch = self.channel(number)
        if not ch.cfg.can_move:
            raise Refused(f"channel {ch.number} has no robot, so no servo", FLAG_UNSUPPORTED)
        if not on:
            ch.halt()

            def finish_off() -> None:
                ch.servo = False

            return SERVO_OFF_TIME, finish_off
        if self.alarms.on_channel(ch.number):
            raise Refused(f"channel {ch.number} has an alarm; reset it with CG before servo on")

        def finish_on() -> None:
            if self.alarms.on_channel(ch.number):
                raise Refused(f"an alarm came up on channel {ch.number}; servo stays off")
            ch.servo = True

        return (0.0 if ch.servo else SERVO_ON_TIME), finish_on

    def set_speed(self, number: int, speed: int) -> None:
        self.channel(number).speed = speed
        self.changed()

    def set_reference_axis(self, number: int, axis: int) -> None:
        ch = self.channel(number)
        if ch.servo:
            raise Refused(f"servo is on (channel {ch.number}); CX needs the servo off")
        if axis > ch.cfg.axes:
            raise Refused(f"axis {axis} is not used on channel {ch.number} ({ch.cfg.axes} axes)")
        ch.reference_axis = axis
