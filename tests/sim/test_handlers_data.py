"""GA-GD, GR/GW, KD and KE through a real HostLink."""

from __future__ import annotations

import pytest
from sim_harness import Failure, Harness

from robostar.commands.io import ReadInputs, ReadIOBoards, ReadOutputs, SetOutput
from robostar.commands.motion import Move
from robostar.commands.system import ReadLastError, ReadParameters
from robostar.commands.variables import (
    ReadGlobalFloat,
    ReadGlobalInt,
    ReadGlobalPoint,
    WriteGlobalFloat,
    WriteGlobalInt,
    WriteGlobalPoint,
)
from robostar.protocol.packets import Shape
from robostar.sim import ChannelConfig, SimConfig
from robostar.sim.parameters import BGT_TEXT, CHANNEL_NAMES, PUBLIC_NAMES
from robostar.types import ArmForm, CoordSystem, MotionType, Point, RobotType

ANGLE, XY = CoordSystem.ANGLE, CoordSystem.XY


# -- I/O ---------------------------------------------------------------------------------------
def test_inputs_come_from_outside():
    h = Harness()
    assert h.ok(ReadInputs(1)).on == ()
    h.model.set_input(1, 0, True)
    h.model.set_input(1, 15, True)
    assert h.ok(ReadInputs(1)).on == (0, 15)


def test_outputs_are_set_by_gc_and_read_by_gb():
    h = Harness()
    h.ok(SetOutput(1, 12, True))
    h.ok(SetOutput(0, 3, True))
    assert h.ok(ReadOutputs(1)).on == (12,)
    assert h.ok(ReadOutputs(0)).on == (3,)
    h.ok(SetOutput(1, 12, False))
    assert h.ok(ReadOutputs(1)).on == ()
    assert h.controller.executions["GC"] == 3


def test_ports_beyond_the_boards_are_refused():
    h = Harness(io_boards=(2, 0))
    assert h.ok(ReadIOBoards()) == (2, 0)
    h.ok(ReadInputs(4))
    assert "output port 1 does not exist" in h.fail(SetOutput(1, 0, True))
    assert "output port 1" in h.fail(ReadOutputs(1))
    h.ok(SetOutput(0, 0, True))
    assert "input port" in Harness(io_boards=(0, 0)).fail(ReadInputs(1))


def test_a_port_sent_as_a_raw_byte_is_0x31():
    h = Harness()
    result = h.raw(b"\xffGA0\x01")
    assert isinstance(result, Failure) and result.flag == 0x31
    assert "port" in result.reason
    assert h.raw(b"\xffGC0516" + b"1") == Failure(0x31, "GC port: 5 is out of range 0..4")


# -- globals -----------------------------------------------------------------------------------
def test_global_ints_and_floats():
    h = Harness()
    assert h.ok(ReadGlobalInt(499)) == 0
    h.ok(WriteGlobalInt(499, -99999))
    h.ok(WriteGlobalFloat(0, -1234.567))
    assert h.ok(ReadGlobalInt(499)) == -99999
    assert h.ok(ReadGlobalFloat(0)) == -1234.567


def test_a_float_only_gws_width_holds_is_answered_in_ten_bytes():
    # The manual draws GR's float in 9 bytes; a value GW accepted in 10 comes back in 10
    # rather than being refused (issue #19): the host reads any width.
    h = Harness()
    h.ok(WriteGlobalFloat(1, 123456.125))
    assert h.ok(ReadGlobalFloat(1)) == 123456.125


@pytest.mark.parametrize(
    ("data", "field"),
    [
        (b"\xffGR1 500", "index"),
        (b"\xffGR00000 1024", "index"),
    ],
)
def test_global_indexes_beyond_the_manuals_are_0x31(data, field):
    result = Harness().raw(data)
    assert isinstance(result, Failure) and result.flag == 0x31 and field in result.reason


def test_global_points_in_angles_all_axes():
    h = Harness()
    empty = h.ok(ReadGlobalPoint(1, 1023))
    assert empty == Point((0.0,) * 6, ArmForm.NONE, False)
    h.ok(WriteGlobalPoint(1, 1023, Point((10.0, 20.0, 30.0, 40.0), ArmForm.RIGHT)))
    assert h.ok(ReadGlobalPoint(1, 1023)) == Point(
        (10.0, 20.0, 30.0, 40.0, 0.0, 0.0), ArmForm.RIGHT, True
    )


def test_global_points_in_xy_go_through_the_kinematics():
    h = Harness()
    h.ok(WriteGlobalPoint(1, 5, Point((300.0, 200.0, 10.0, 0.0), ArmForm.LEFT), XY))
    stored = h.ok(ReadGlobalPoint(1, 5))
    assert stored.arm is ArmForm.LEFT and stored.axes[1] < 0
    assert h.ok(ReadGlobalPoint(1, 5, XY)).axes == pytest.approx(
        (300.0, 200.0, 10.0, 0.0, 0.0, 0.0), abs=1e-3
    )
    assert "reaches" in h.fail(WriteGlobalPoint(1, 6, Point((900.0, 0.0, 0.0, 0.0)), XY))


def test_global_point_arm_none_keeps_the_robots_current_posture():
    h = Harness()
    h.model.channel(1).joints = (0.0, -40.0, 0.0, 0.0)  # left arm
    h.ok(WriteGlobalPoint(1, 7, Point((300.0, 200.0, 0.0, 0.0), ArmForm.NONE), XY))
    assert h.ok(ReadGlobalPoint(1, 7)).arm is ArmForm.LEFT


def test_global_point_one_axis_reads_and_writes():
    h = Harness()
    h.ok(WriteGlobalPoint(1, 2, Point((10.0, 20.0, 30.0, 40.0), ArmForm.RIGHT)))
    h.ok(WriteGlobalPoint(1, 2, Point((99.5,), ArmForm.RIGHT, True), axis=3))
    assert h.ok(ReadGlobalPoint(1, 2)).axes[:4] == (10.0, 20.0, 99.5, 40.0)
    assert h.ok(ReadGlobalPoint(1, 2, axis=2)) == Point((20.0,), ArmForm.NONE, True)
    x_before = h.ok(ReadGlobalPoint(1, 2, XY, axis=1)).axes[0]
    h.ok(WriteGlobalPoint(1, 2, Point((x_before - 20.0,), ArmForm.RIGHT, True), XY, axis=1))
    assert h.ok(ReadGlobalPoint(1, 2, XY, axis=1)).axes[0] == pytest.approx(x_before - 20.0)


def test_global_points_belong_to_their_channel():
    h = Harness()
    h.ok(WriteGlobalPoint(2, 0, Point((1.0, 2.0))))
    assert h.ok(ReadGlobalPoint(1, 0)).used is False
    assert h.ok(ReadGlobalPoint(2, 0)).axes[:2] == (1.0, 2.0)
    assert "not configured" in h.fail(ReadGlobalPoint(3, 0))


# -- KD, KE ------------------------------------------------------------------------------------
def test_kd_keeps_the_last_error_for_every_channel():
    h = Harness()
    assert h.ok(ReadLastError()) == "no error"
    h.fail(Move(2, MotionType.JOINT, ANGLE, ((1.0, 2.0),)))
    reason = h.ok(ReadLastError())
    assert "origin" in reason
    h.ok(ReadInputs(0))
    assert h.ok(ReadLastError()) == reason  # a success does not clear it


def test_ke_public_parameters_one_packet_each():
    h = Harness(speedup=100.0)
    h.wait_model(90061.0)
    texts = h.ok(ReadParameters(None))
    assert len(texts) == len(PUBLIC_NAMES)
    assert "AUTO SVON: ENB" in texts
    assert "MAX_CH: 2" in texts
    assert "NAME: N1-SIM" in texts
    assert "W.TIMER: 1D 01:01:01" in texts
    assert h.ok(ReadParameters(None, 8)) == ("AUTO SVON: ENB",)
    assert Harness(auto_servo_on=False).ok(ReadParameters(None, 8)) == ("AUTO SVON: DIS",)


def test_ke_channel_parameters():
    h = Harness()
    texts = h.ok(ReadParameters(1))
    assert len(texts) == len(CHANNEL_NAMES)
    assert h.ok(ReadParameters(1, 1)) == ("CONF: SCARA 4 AXIS MODEL RSA60A",)
    assert h.ok(ReadParameters(1, 2)) == ("LENG: 350.000 250.000",)
    assert h.ok(ReadParameters(2, 72)) == ("USING AXIS: 1 2",)
    assert "no parameter 13" in h.fail(ReadParameters(1, 13))
    assert "not configured" in h.fail(ReadParameters(3, 1))


def test_ke_of_a_background_task_channel_is_its_bgt_text():
    config = SimConfig(
        channels=(ChannelConfig(RobotType.XY, 2), ChannelConfig(RobotType.BACKGROUND_TASK, 1))
    )
    assert Harness(config).ok(ReadParameters(2, 3)) == (BGT_TEXT,)


def test_ke_answers_are_multi_packet():
    h = Harness()
    packets = h.raw(b"\xffKE4-1", Shape.MULTI)
    assert isinstance(packets, list)
    assert len(packets) == len(PUBLIC_NAMES) + 1
    assert packets[-1] == b"\xff\x34"
