"""BA-BG and CI through a real HostLink: motion in model time and the rules that guard it."""

from __future__ import annotations

import math

import pytest
from sim_harness import Harness

from robostar.commands.control import SetSpeed, StopHoming
from robostar.commands.job import Servo
from robostar.commands.motion import (
    Home,
    JogContinue,
    JogStart,
    JogStop,
    Move,
    MoveBy,
    MoveToPoint,
)
from robostar.commands.status import ReadAlarms, ReadPosition, ReadStatus
from robostar.sim import ChannelConfig, SimConfig
from robostar.sim.alarms import AlarmCode
from robostar.types import ArmForm, CoordSystem, JogDirection, MotionType, PositionKind, RobotType

J, L, A, C = MotionType.JOINT, MotionType.LINEAR, MotionType.ARC, MotionType.CIRCLE
ANGLE, XY = CoordSystem.ANGLE, CoordSystem.XY


def homed(**fields) -> Harness:
    h = Harness(**fields)
    for channel in range(1, len(h.model.channels) + 1):
        if h.model.channel(channel).cfg.can_move:
            h.ok(Home(channel))
    h.wait_model(2.1)
    return h


def position(h: Harness, channel: int, kind=PositionKind.ANGLE) -> tuple[float, ...]:
    return h.ok(ReadPosition(channel, kind)).axes


def alarm_codes(h: Harness) -> list[int]:
    return [a.code for a in h.ok(ReadAlarms())]


def test_homing_takes_two_model_seconds_and_sets_origin():
    h = Harness()
    h.model.channel(1).joints = (40.0, 50.0, 60.0, 70.0)
    h.ok(Home(1))
    h.wait_model(1.0)
    status = h.ok(ReadStatus())[0]
    assert status.running and not status.origin
    assert position(h, 1) == pytest.approx((20.0, 25.0, 30.0, 35.0), abs=0.1)
    h.wait_model(1.1)
    status = h.ok(ReadStatus())[0]
    assert status.origin and status.servo_on and not status.running
    assert position(h, 1) == (0.0, 0.0, 0.0, 0.0)
    assert h.controller.executions["BA"] == 1


def test_ci_stops_homing_and_auto_servo_turns_the_servo_off():
    h = Harness()
    h.ok(Home(1))
    h.wait_model(0.5)
    h.ok(StopHoming(1))
    h.wait_model(3.0)
    status = h.ok(ReadStatus())[0]
    assert not status.origin and not status.servo_on and not status.running


def test_ci_with_auto_servo_dis_keeps_the_servo_on():
    h = Harness(auto_servo_on=False)
    h.ok(Servo(1, True))
    h.ok(Home(1))
    h.ok(StopHoming(1))
    status = h.ok(ReadStatus())[0]
    assert status.servo_on and not status.origin


def test_auto_servo_dis_needs_db_first():
    h = Harness(auto_servo_on=False)
    for command in (
        Home(1),
        JogStart(1, 1, JogDirection.PLUS, J),
    ):
        assert "servo off" in h.fail(command)
    assert h.controller.executions == {}
    h.ok(Servo(1, True))
    h.ok(Home(1))


def test_auto_servo_enb_turns_the_servo_on_for_motion():
    h = Harness()
    assert not h.ok(ReadStatus())[0].servo_on
    h.ok(JogStart(1, 1, JogDirection.PLUS, J))
    assert h.ok(ReadStatus())[0].servo_on


@pytest.mark.parametrize(
    "command",
    [
        MoveToPoint(1, "DEMO.PNT", J, 1),
        Move(1, J, ANGLE, ((10.0, 20.0, 30.0, 0.0),)),
        MoveBy(1, J, ANGLE, (10.0, 0.0, 0.0, 0.0)),
    ],
)
def test_moves_before_origin_raise_run_fail(command):
    h = Harness()
    assert "origin return (BA) is not done on channel 1" in h.fail(command)
    assert alarm_codes(h) == [AlarmCode.RUN_FAIL]
    assert not h.ok(ReadStatus())[0].servo_on  # refused before the servo came on


def test_motion_with_an_alarm_is_refused_until_cg():
    h = homed()
    h.model.raise_alarm(AlarmCode.TP_EMERGENCY, 1)
    assert "alarm" in h.fail(Move(1, J, ANGLE, ((10.0, 20.0, 30.0, 0.0),)))
    assert "alarm" in h.fail(Home(1))


def test_a_moving_channel_is_busy():
    h = homed()
    h.ok(Move(1, J, ANGLE, ((100.0, 100.0, 100.0, 0.0),)))
    assert "busy" in h.fail(Move(1, J, ANGLE, ((0.0, 0.0, 0.0, 0.0),)))
    assert "busy" in h.fail(Home(1))


def test_joint_move_runs_in_model_time_at_the_set_speed():
    h = homed()
    h.ok(SetSpeed(1, 100))  # 36 deg/s on axes 1-2
    h.ok(Move(1, J, ANGLE, ((36.0, -36.0, 50.0, 0.0),)))
    h.wait_model(0.5)
    assert position(h, 1) == pytest.approx((18.0, -18.0, 25.0, 0.0), abs=0.1)
    assert h.ok(ReadStatus())[0].running
    h.wait_model(0.6)
    assert position(h, 1) == pytest.approx((36.0, -36.0, 50.0, 0.0))
    status = h.ok(ReadStatus())[0]
    assert status.in_position and not status.running


def test_linear_move_in_xy_keeps_a_straight_line():
    h = homed()
    h.ok(Move(1, J, XY, ((300.0, 100.0, 0.0, 0.0),)))
    h.until(lambda: not h.model.channel(1).moving)
    h.ok(Move(1, L, XY, ((300.0, 300.0, 0.0, 0.0),)))
    seen = []
    while h.model.channel(1).moving:
        seen.append(position(h, 1, PositionKind.XY))
        h.wait_model(0.02)
    assert len(seen) > 3
    assert all(p[0] == pytest.approx(300.0, abs=0.5) for p in seen)
    assert position(h, 1, PositionKind.XY)[:2] == pytest.approx((300.0, 300.0), abs=1e-3)


def test_arc_and_circle_on_a_cartesian_channel():
    h = homed()
    h.ok(Move(2, J, ANGLE, ((200.0, 100.0),)))
    h.until(lambda: not h.model.channel(2).moving)
    h.ok(Move(2, A, XY, ((300.0, 200.0), (400.0, 100.0))))
    high = 0.0
    while h.model.channel(2).moving:
        x, y = position(h, 2)
        assert math.dist((x, y), (300.0, 100.0)) == pytest.approx(100.0, abs=1.0)
        high = max(high, y)
        h.wait_model(0.01)
    assert high == pytest.approx(200.0, abs=2.0)
    assert position(h, 2) == pytest.approx((400.0, 100.0))
    h.ok(Move(2, C, XY, ((300.0, 0.0), (200.0, 100.0))))
    h.until(lambda: not h.model.channel(2).moving)
    assert position(h, 2) == pytest.approx((400.0, 100.0))


def test_target_outside_the_soft_limits_raises_an_alarm_and_0x32():
    h = homed()
    reason = h.fail(Move(1, J, ANGLE, ((150.0, 0.0, 0.0, 0.0),)))
    assert "axis 1" in reason and "soft limits" in reason
    assert alarm_codes(h) == [AlarmCode.SOFT_LIMIT]
    assert h.ok(ReadStatus())[0].alarm
    assert position(h, 1) == (0.0, 0.0, 0.0, 0.0)


def test_xy_target_out_of_reach_raises_an_alarm():
    h = homed()
    assert "reaches" in h.fail(Move(1, J, XY, ((900.0, 0.0, 0.0, 0.0),)))
    assert alarm_codes(h) == [AlarmCode.OUT_OF_REACH]


def test_arc_through_points_on_a_line_is_a_path_error():
    h = homed()
    assert "one line" in h.fail(Move(2, A, XY, ((100.0, 100.0), (200.0, 200.0))))
    assert alarm_codes(h) == [AlarmCode.PATH_ERROR]


def test_axis_count_must_cover_the_channel():
    h = homed()
    assert "4 axes" in h.fail(Move(1, J, ANGLE, ((1.0, 2.0),)))
    assert "beyond" in h.fail(Move(2, J, ANGLE, ((1.0, 2.0, 3.0),)))
    h.ok(Move(2, J, ANGLE, ((1.0, 2.0, 0.0, 0.0, 0.0, 0.0),)))  # zero padding is fine


def test_speed_zero_refuses_motion():
    h = homed()
    h.ok(SetSpeed(1, 0))
    assert "speed is 0" in h.fail(MoveBy(1, J, ANGLE, (1.0, 0.0, 0.0, 0.0)))


def test_background_task_channel_has_no_robot():
    config = SimConfig(
        speedup=50.0,
        channels=(ChannelConfig(RobotType.XY, 2), ChannelConfig(RobotType.BACKGROUND_TASK, 1)),
    )
    h = Harness(config)
    h.fail(Home(2), flag=0x33)
    h.fail(Servo(2, True), flag=0x33)


def test_relative_moves_in_angles_and_xy():
    h = homed()
    h.ok(Move(1, J, ANGLE, ((10.0, 90.0, 20.0, 0.0),)))
    h.until(lambda: not h.model.channel(1).moving)
    h.ok(MoveBy(1, J, ANGLE, (5.0, -10.0, 10.0, 0.0)))
    h.until(lambda: not h.model.channel(1).moving)
    assert position(h, 1) == pytest.approx((15.0, 80.0, 30.0, 0.0))
    before = position(h, 1, PositionKind.XY)
    h.ok(MoveBy(1, L, XY, (0.0, 50.0, 0.0, 0.0)))
    h.until(lambda: not h.model.channel(1).moving)
    after = position(h, 1, PositionKind.XY)
    assert after == pytest.approx((before[0], before[1] + 50.0, *before[2:]), abs=1e-3)


def test_move_to_pnt_points():
    h = homed()
    h.ok(MoveToPoint(1, "DEMO.PNT", J, 1))
    h.until(lambda: not h.model.channel(1).moving)
    assert position(h, 1) == pytest.approx((30.0, 60.0, 50.0, 0.0))
    h.ok(MoveToPoint(1, "demo.pnt", L, 2))
    h.until(lambda: not h.model.channel(1).moving)
    assert position(h, 1) == pytest.approx((0.0, 60.0, 50.0, 0.0))
    h.ok(MoveToPoint(1, "DEMO.PNT", J, 1))
    h.until(lambda: not h.model.channel(1).moving)
    h.ok(MoveToPoint(1, "DEMO.PNT", A, 2, 3))
    h.until(lambda: not h.model.channel(1).moving)
    assert position(h, 1) == pytest.approx((-30.0, 90.0, 100.0, 45.0))


@pytest.mark.parametrize(
    ("command", "text"),
    [
        (MoveToPoint(1, "NONE.PNT", J, 1), "no file NONE.PNT"),
        (MoveToPoint(1, "DEMO.PNT", J, 99), "P99"),
    ],
)
def test_move_to_a_missing_point_is_run_fail(command, text):
    h = homed()
    assert text in h.fail(command)
    assert alarm_codes(h) == [AlarmCode.RUN_FAIL]


def test_jog_runs_while_bf_keeps_coming_and_stops_500ms_after_the_last():
    h = homed(speedup=1.0)
    h.ok(SetSpeed(2, 100))  # 100 mm/s
    h.ok(JogStart(2, 1, JogDirection.PLUS, J))
    for _ in range(4):
        h.wait(0.3)
        h.ok(JogContinue(2))
    assert h.model.channel(2).jog is not None
    h.wait(0.45)
    assert h.model.channel(2).jog is not None
    h.wait(0.1)
    assert h.model.channel(2).jog is None
    x = position(h, 2)[0]
    assert x == pytest.approx(100.0 * 1.7, abs=1.0)  # 4 x 0.3 s + 0.5 s of jog
    h.wait(1.0)
    assert position(h, 2)[0] == x
    assert "no jog" in h.fail(JogContinue(2))


def test_the_jog_watchdog_is_real_time_whatever_the_speedup():
    h = homed(speedup=50.0)
    h.ok(SetSpeed(2, 10))  # 10 mm/s of model time
    h.ok(JogStart(2, 2, JogDirection.PLUS, J))
    h.wait(0.49)
    assert h.model.channel(2).jog is not None
    h.wait(0.02)
    assert h.model.channel(2).jog is None
    assert position(h, 2)[1] == pytest.approx(10.0 * 50 * 0.5, abs=1.0)


def test_bg_stops_a_jog_at_once():
    h = homed()
    h.ok(JogStart(2, 1, JogDirection.PLUS, J))
    h.wait(0.1)
    h.ok(JogStop(2))
    x = position(h, 2)[0]
    h.wait(0.3)
    assert position(h, 2)[0] == x
    assert not h.ok(ReadStatus())[1].running
    h.ok(JogStop(2))  # stopping again is harmless


def test_jog_stops_at_the_soft_limit():
    h = homed(speedup=1.0)
    h.ok(SetSpeed(2, 1000))
    h.ok(JogStart(2, 1, JogDirection.MINUS, J))
    h.wait(0.3)
    assert position(h, 2)[0] == pytest.approx(0.0, abs=1e-6)
    assert alarm_codes(h) == []


def test_linear_jog_on_a_scara_moves_along_x():
    h = homed()
    h.ok(Move(1, J, XY, ((300.0, 100.0, 0.0, 0.0),)))
    h.until(lambda: not h.model.channel(1).moving)
    h.ok(SetSpeed(1, 10))
    h.ok(JogStart(1, 1, JogDirection.PLUS, L))
    h.wait(0.2)
    h.ok(JogStop(1))
    x, y, z, w = position(h, 1, PositionKind.XY)
    assert x > 300.0 + 1.0
    assert (y, z, w) == pytest.approx((100.0, 0.0, 0.0), abs=1e-3)
    assert h.ok(ReadPosition(1, PositionKind.XY)).arm is ArmForm.RIGHT


def test_jog_of_an_axis_the_channel_lacks_is_refused():
    h = homed()
    assert "axis 3" in h.fail(JogStart(2, 3, JogDirection.PLUS, J))
