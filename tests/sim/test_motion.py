"""Path planning: joint moves arrive together, lines are straight, arcs pass their via points."""

from __future__ import annotations

import math

import pytest

from robostar.sim import ChannelConfig
from robostar.sim.kinematics import to_joints, to_xy
from robostar.sim.motion import (
    HOMING_TIME,
    PathError,
    PathProblem,
    plan_arc,
    plan_circle,
    plan_homing,
    plan_joint,
    plan_linear,
)
from robostar.types import ArmForm, RobotType

SCARA = ChannelConfig(RobotType.SCARA, 4)
XY = ChannelConfig(RobotType.XY, 2)
START = (0.0, 90.0, 0.0, 0.0)


def joints_at(x: float, y: float, z: float = 0.0, w: float = 90.0) -> tuple[float, ...]:
    return to_joints(SCARA, (x, y, z, w), ArmForm.RIGHT)


def test_joint_move_lasts_as_long_as_the_slowest_axis_and_all_arrive_together():
    path = plan_joint(SCARA, START, (36.0, 72.0, 100.0, 0.0), speed=100)
    # axis 1: 36 deg at 36 deg/s; axis 3: 100 mm at 100 mm/s -> both 1 s; axis 2 is faster.
    assert path.duration == pytest.approx(1.0)
    half = path.at(0.5)
    moved = [(h, s, e) for h, s, e in zip(half, START, path.end, strict=True) if e != s]
    fractions = [(h - s) / (e - s) for h, s, e in moved]
    assert fractions == pytest.approx([0.5] * len(fractions))
    assert path.at(5.0) == path.end


def test_speed_scales_the_duration():
    slow = plan_joint(SCARA, START, (30.0, 90.0, 0.0, 0.0), speed=100)
    fast = plan_joint(SCARA, START, (30.0, 90.0, 0.0, 0.0), speed=1000)
    assert slow.duration == pytest.approx(10 * fast.duration)


def test_joint_target_outside_the_limits_is_refused():
    with pytest.raises(PathError) as info:
        plan_joint(SCARA, START, (130.0, 0.0, 0.0, 0.0), speed=500)
    assert info.value.problem is PathProblem.LIMIT


def test_linear_move_stays_on_the_straight_line():
    a, b = joints_at(300.0, 100.0), joints_at(300.0, 300.0)
    path = plan_linear(SCARA, a, b, speed=500)
    assert path.duration >= 200.0 / (SCARA.linear_speed * 0.5)
    for i in range(1, 20):
        x, y, *_ = to_xy(SCARA, path.at(path.duration * i / 20))
        assert x == pytest.approx(300.0, abs=0.5)
        assert 100.0 - 0.5 <= y <= 300.0 + 0.5


def test_linear_move_cannot_change_the_arm_form():
    a = joints_at(300.0, 100.0)
    b = to_joints(SCARA, (300.0, 300.0, 0.0, 90.0), ArmForm.LEFT)
    with pytest.raises(PathError) as info:
        plan_linear(SCARA, a, b, speed=500)
    assert info.value.problem is PathProblem.SHAPE


def test_linear_move_through_the_unreachable_centre_is_refused():
    a, b = joints_at(300.0, 10.0), joints_at(-300.0, 10.0)
    with pytest.raises(PathError) as info:
        plan_linear(SCARA, a, b, speed=500)
    assert info.value.problem in (PathProblem.REACH, PathProblem.LIMIT)


def test_arc_passes_its_via_point_and_ends_at_the_target():
    a, via, b = joints_at(500.0, 0.0), joints_at(400.0, 100.0), joints_at(300.0, 0.0)
    path = plan_arc(SCARA, a, via, b, speed=500)
    points = [to_xy(SCARA, path.at(path.duration * i / 200)) for i in range(201)]
    assert min(math.dist(p[:2], (400.0, 100.0)) for p in points) < 2.0
    for p in points:  # on the circle of radius 100 around (400, 0)
        assert math.dist(p[:2], (400.0, 0.0)) == pytest.approx(100.0, abs=1.0)
    assert to_xy(SCARA, path.at(path.duration))[:2] == pytest.approx((300.0, 0.0))


def test_circle_goes_all_the_way_round_and_back():
    a, v1, v2 = joints_at(500.0, 0.0), joints_at(400.0, 100.0), joints_at(300.0, 0.0)
    path = plan_circle(SCARA, a, v1, v2, speed=500)
    assert path.end == a
    points = [to_xy(SCARA, path.at(path.duration * i / 200)) for i in range(201)]
    assert min(p[1] for p in points) == pytest.approx(-100.0, abs=1.5)
    assert path.duration >= 2 * math.pi * 100.0 / (SCARA.linear_speed * 0.5)


def test_points_on_one_line_make_no_arc():
    a, via, b = (100.0, 100.0), (200.0, 200.0), (300.0, 300.0)
    with pytest.raises(PathError) as info:
        plan_arc(XY, a, via, b, speed=500)
    assert info.value.problem is PathProblem.SHAPE


def test_cartesian_line_is_joint_interpolation():
    path = plan_linear(XY, (0.0, 0.0), (300.0, 400.0), speed=1000)
    assert path.duration == pytest.approx(0.4)
    assert path.at(0.2) == pytest.approx((150.0, 200.0), abs=0.01)


def test_homing_takes_its_fixed_time_to_zero():
    path = plan_homing(XY, (300.0, 400.0))
    assert path.duration == HOMING_TIME
    assert path.end == (0.0, 0.0)
