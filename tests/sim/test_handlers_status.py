"""AA-AD and the answers to what does not decode, through a real HostLink."""

from __future__ import annotations

import pytest
from sim_harness import Failure, Harness

from robostar.commands import all_commands
from robostar.commands.status import ReadAlarms, ReadInfo, ReadPosition, ReadStatus
from robostar.commands.system import ReadLastError
from robostar.protocol.frame import encode_packet
from robostar.sim import ChannelConfig, SimConfig
from robostar.sim.alarms import AlarmCode
from robostar.sim.handlers import HANDLERS
from robostar.types import Alarm, ArmForm, ChannelStatus, PositionKind, RobotType


def test_every_catalogue_command_has_a_handler():
    assert set(all_commands()) == set(HANDLERS)


def test_aa_reports_each_channel_and_unused_channels_as_0x80():
    h = Harness()
    one, two, three = h.ok(ReadStatus())
    assert one == ChannelStatus(ready=True)
    assert two == ChannelStatus(ready=True)
    assert three.to_byte() == 0x80
    h.model.raise_alarm(AlarmCode.RUN_FAIL, 2)
    _, two, _ = h.ok(ReadStatus())
    assert two.alarm and not two.ready


def test_aa_bits_follow_servo_origin_motion():
    h = Harness()
    h.model.home(1)
    moving = h.ok(ReadStatus())[0]
    assert moving == ChannelStatus(servo_on=True, ready=True, running=True)
    h.wait_model(2.5)
    homed = h.ok(ReadStatus())[0]
    assert homed == ChannelStatus(servo_on=True, origin=True, ready=True, in_position=True)
    assert homed.to_byte() == 0xB6


def test_ab_lists_the_current_alarms():
    h = Harness()
    assert h.ok(ReadAlarms()) == ()
    h.model.raise_alarm(1153, 9)
    h.model.raise_alarm(1104, 1)
    assert h.ok(ReadAlarms()) == (Alarm(1153, "T/P Emergency"), Alarm(1104, "Servo Not Redy"))


def test_ac_reads_pulses_angles_and_xy():
    h = Harness()
    ch = h.model.channel(1)
    ch.joints = (30.0, 60.0, 50.0, 10.0)
    pulses = h.ok(ReadPosition(1, PositionKind.PULSE))
    assert pulses.axes == (30000, 60000, 25000, 5000)
    assert pulses.arm is ArmForm.NONE
    angles = h.ok(ReadPosition(1, PositionKind.ANGLE))
    assert angles.axes == (30.0, 60.0, 50.0, 10.0)
    assert angles.arm is ArmForm.NONE
    xy = h.ok(ReadPosition(1, PositionKind.XY))
    assert xy.axes == pytest.approx((303.109, 425.0, 50.0, 100.0), abs=1e-3)
    assert xy.arm is ArmForm.RIGHT


def test_ac_on_a_cartesian_channel_is_mm_both_ways():
    h = Harness()
    h.model.channel(2).joints = (120.5, 33.25)
    assert h.ok(ReadPosition(2, PositionKind.ANGLE)).axes == (120.5, 33.25)
    xy = h.ok(ReadPosition(2, PositionKind.XY))
    assert xy.axes == (120.5, 33.25) and xy.arm is ArmForm.NONE


def test_ac_beyond_max_ch_is_refused():
    h = Harness()
    reason = h.fail(ReadPosition(3, PositionKind.ANGLE))
    assert "channel 3 is not configured" in reason


def test_ad_describes_the_controller():
    config = SimConfig(
        name="CELL-2",
        channels=(ChannelConfig(RobotType.SCARA, 4), ChannelConfig(RobotType.BACKGROUND_TASK, 1)),
    )
    info = Harness(config).ok(ReadInfo())
    assert (info.max_channels, info.name, info.version) == (2, "CELL-2", "N1RO 03.02.05-SIM")
    scara, bgt, unused = info.channels
    assert (scara.model, scara.robot_type, scara.max_axes, scara.axes_in_use) == (
        "RSA60A",
        RobotType.SCARA,
        4,
        (1, 2, 3, 4),
    )
    assert (bgt.model, bgt.robot_type, bgt.axes_in_use) == ("BGT", RobotType.BACKGROUND_TASK, ())
    assert unused.robot_type is RobotType.NOT_DEFINED


def test_unknown_command_is_0x31_and_kd_says_why():
    h = Harness()
    result = h.raw(b"\xffZZ")
    assert isinstance(result, Failure)
    assert result.flag == 0x31
    assert "'ZZ' is not a command" in result.reason


def test_kd_text_stays_printable_ascii():
    h = Harness()
    result = h.raw(b"\xff\xc3\xa9")
    assert result == Failure(0x31, "?? command: '??' is not a command of the protocol")


def test_bad_field_answers_the_field_errors_flag_and_kd_names_it():
    h = Harness()
    result = h.raw(b"\xffAC07")  # type 7 does not exist
    assert result == Failure(0x31, "AC type: 7 is out of range 0..2")
    too_long = h.raw(b"\xffBB0" + b"ABCDEF.PNT".rjust(12) + b"000010000")
    assert isinstance(too_long, Failure) and too_long.flag == 0x32
    assert "more than 5 characters" in too_long.reason


def test_error_answer_keeps_the_commands_dummy_byte():
    h = Harness()
    packets, error = h.exchange_raw(b"\xffAD" + b"X")  # AD answers FF FLAG
    assert error is not None and packets == [b"\xff\x31"]
    packets, error = h.exchange_raw(b"\xffAA" + b"X")
    assert packets == [b"\x31"]


def test_a_corrupt_packet_is_nakked_and_kd_reports_the_lrc():
    h = Harness()
    good = encode_packet(b"\xffAA")
    h.controller.feed(good[:-1] + bytes((good[-1] ^ 0x55,)), h.now)
    assert h.controller.output(h.now) == b"\x15"  # NAK
    assert h.controller.requests == 0
    assert h.ok(ReadLastError()) == "LRC is different with received data LRC"


def test_requests_are_counted():
    h = Harness()
    h.ok(ReadStatus())
    h.raw(b"\xffZZ")
    assert h.controller.requests == 3  # AA, ZZ and the KD read after it
