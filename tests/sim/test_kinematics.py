"""SCARA forward/inverse kinematics, arm form, pulses and soft limits."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.sim import ChannelConfig
from robostar.sim.kinematics import (
    Unreachable,
    arm_of,
    limit_problem,
    to_joints,
    to_pulses,
    to_xy,
)
from robostar.types import ArmForm, RobotType

SCARA = ChannelConfig(RobotType.SCARA, 4)
XY = ChannelConfig(RobotType.XY, 3)


def test_forward_kinematics_of_known_postures():
    assert to_xy(SCARA, (0.0, 0.0, 10.0, 0.0)) == pytest.approx((600.0, 0.0, 10.0, 0.0))
    x, y, z, w = to_xy(SCARA, (90.0, 90.0, 0.0, 30.0))
    assert (x, y, z, w) == pytest.approx((-250.0, 350.0, 0.0, 210.0))


def test_arm_form_follows_the_elbow():
    assert arm_of(SCARA, (0.0, 30.0, 0.0, 0.0)) is ArmForm.RIGHT
    assert arm_of(SCARA, (0.0, -30.0, 0.0, 0.0)) is ArmForm.LEFT
    assert arm_of(XY, (1.0, 2.0, 3.0)) is ArmForm.NONE


@given(
    j1=st.floats(-120, 120),
    j2=st.floats(1, 145) | st.floats(-145, -1),
    z=st.floats(0, 200),
    w=st.floats(-360, 360),
)
def test_inverse_kinematics_returns_the_same_joints(j1, j2, z, w):
    joints = (j1, j2, z, w)
    back = to_joints(SCARA, to_xy(SCARA, joints), arm_of(SCARA, joints))
    assert back == pytest.approx(joints, abs=1e-6)


def test_both_arm_forms_reach_the_same_point():
    right = to_joints(SCARA, (300.0, 200.0, 0.0, 0.0), ArmForm.RIGHT)
    left = to_joints(SCARA, (300.0, 200.0, 0.0, 0.0), ArmForm.LEFT)
    assert right[1] > 0 > left[1]
    assert to_xy(SCARA, right) == pytest.approx(to_xy(SCARA, left))


@pytest.mark.parametrize("xy", [(700.0, 0.0), (50.0, 0.0), (0.0, 0.0)])
def test_points_out_of_reach_are_refused(xy):
    with pytest.raises(Unreachable, match="reaches"):
        to_joints(SCARA, (*xy, 0.0, 0.0), ArmForm.RIGHT)


def test_cartesian_robot_angle_is_mm():
    assert to_xy(XY, (10.0, 20.0, 30.0)) == (10.0, 20.0, 30.0)
    assert to_joints(XY, (10.0, 20.0, 30.0), ArmForm.NONE) == (10.0, 20.0, 30.0)


def test_pulses_use_each_axis_scale():
    assert to_pulses(SCARA, (1.5, -2.0, 10.0, 0.002)) == (1500, -2000, 5000, 1)


def test_limit_problem_names_the_axis():
    assert limit_problem(SCARA, (0.0, 0.0, 0.0, 0.0)) is None
    assert "axis 3" in (limit_problem(SCARA, (0.0, 0.0, 250.0, 0.0)) or "")
    assert math.isclose(SCARA.limits[0][1], 120.0)
