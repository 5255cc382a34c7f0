"""Data operations: I/O contacts, global variables and KE parameters."""

from __future__ import annotations

from robostar.sim.kinematics import Unreachable, arm_of, to_joints, to_xy
from robostar.sim.parameters import BGT_TEXT, channel_parameters
from robostar.sim.state import (
    Channel,
    ModelBase,
    Refused,
)
from robostar.types import (
    ArmForm,
    CoordSystem,
    IOState,
    Point,
    RobotType,
)

__all__ = ["DataOps"]

GLOBAL_AXES = 6


class DataOps(ModelBase):
    """GA-GD, GR/GW and KE."""

    # -- I/O -----------------------------------------------------------------------------------
    def _check_port(self, port: int, output: bool) -> None:
        boards = self.config.io_boards[1 if output else 0]
        if port > self.io_ports(output):
            kind = "output" if output else "input"
            raise Refused(
                f"{kind} port {port} does not exist: {boards} {kind} board(s) give ports "
                f"0..{self.io_ports(output)}"
            )

    def set_input(self, port: int, contact: int, on: bool) -> None:
        """Test hook: an input contact changes (the outside world)."""
        self.inputs[port][contact] = on

    def read_inputs(self, port: int) -> IOState:
        self._check_port(port, output=False)
        return IOState(port, tuple(self.inputs[port]))

    def read_outputs(self, port: int) -> IOState:
        self._check_port(port, output=True)
        return IOState(port, tuple(self.outputs[port]))

    def set_output(self, port: int, contact: int, on: bool) -> None:
        self._check_port(port, output=True)
        self.outputs[port][contact] = on
        self.changed()

    # -- globals -------------------------------------------------------------------------------
    def _global_point(self, ch: Channel, index: int) -> Point:
        return ch.points.get(index, Point((0.0,) * GLOBAL_AXES, ArmForm.NONE, False))

    def _as_coords(self, ch: Channel, point: Point, coords: CoordSystem) -> tuple[float, ...]:
        if coords is CoordSystem.ANGLE:
            return point.axes
        axes = ch.cfg.axes
        return to_xy(ch.cfg, point.axes[:axes]) + point.axes[axes:]

    def read_global_point(self, number: int, index: int, coords: CoordSystem, axis: int) -> Point:
        ch = self.channel(number)
        point = self._global_point(ch, index)
        values = self._as_coords(ch, point, coords)
        if axis == 0:
            return Point(values, point.arm, point.used)
        return Point((values[axis - 1],), ArmForm.NONE, point.used)

    def write_global_point(
        self, number: int, index: int, point: Point, coords: CoordSystem, axis: int
    ) -> None:
        ch = self.channel(number)
        # ARM 2 (NONE) asks for the robot's current posture.
        arm = ch.arm if point.arm is ArmForm.NONE else point.arm
        if axis == 0:
            values = list(point.axes) + [0.0] * (GLOBAL_AXES - len(point.axes))
        else:
            values = list(self._as_coords(ch, self._global_point(ch, index), coords))
            values[axis - 1] = point.axes[0]
        axes = ch.cfg.axes
        if coords is CoordSystem.XY:
            try:
                values[:axes] = to_joints(ch.cfg, values[:axes], arm)
            except Unreachable as exc:
                raise Refused(f"global point {index}: {exc}") from None
        if ch.cfg.robot is RobotType.SCARA:
            arm = arm_of(ch.cfg, values[:axes])
        ch.points[index] = Point(tuple(values), arm, point.used)
        self.changed()

    def read_global_int(self, index: int) -> int:
        return self.ints.get(index, 0)

    def write_global_int(self, index: int, value: int) -> None:
        self.ints[index] = value
        self.changed()

    def read_global_float(self, index: int) -> float:
        # Every value GW stored fits GW's 10 bytes; GR answers in 10 when 9 cannot hold it.
        return self.floats.get(index, 0.0)

    def write_global_float(self, index: int, value: float) -> None:
        self.floats[index] = value
        self.changed()

    # -- parameters ----------------------------------------------------------------------------
    def parameters(self, number: int | None, index: int) -> tuple[str, ...]:
        """KE: one parameter's text, or all of them (index -1)."""
        if number is None:
            table = dict(self.public_parameters)
            day, rest = divmod(int(self.clock), 86400)
            table[51] = (
                f"W.TIMER: {day}D {rest // 3600:02d}:{rest % 3600 // 60:02d}:{rest % 60:02d}"
            )
        else:
            ch = self.channel(number)
            if not ch.cfg.can_move:
                return (BGT_TEXT,)
            table = channel_parameters(ch.cfg)
        if index == -1:
            return tuple(table[i] for i in sorted(table))
        if index not in table:
            where = "the public parameters" if number is None else f"channel {number}"
            raise Refused(f"{where} have no parameter {index}")
        return (table[index],)
