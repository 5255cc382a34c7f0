"""C, D and E commands through a real HostLink: speed, servo, jobs, alarms, restart."""

from __future__ import annotations

import pytest
from sim_harness import Failure, Harness

from robostar.commands.control import (
    EmergencyStop,
    ReadReferenceAxis,
    ReadSpeed,
    ResetAlarms,
    ResetJob,
    Restart,
    SetReferenceAxis,
    SetSpeed,
    StartJob,
    StopJob,
)
from robostar.commands.files import UploadFile
from robostar.commands.io import ReadOutputs
from robostar.commands.job import ReadJobName, ReadJobStep, SelectJob, Servo, SetJobMode
from robostar.commands.motion import Home, Move
from robostar.commands.status import ReadAlarms, ReadStatus
from robostar.commands.variables import ReadGlobalInt, WriteGlobalInt
from robostar.protocol.fields import FileName
from robostar.protocol.link import AnswerReceived
from robostar.sim import ChannelConfig, SimConfig
from robostar.sim.alarms import AlarmCode
from robostar.types import CoordSystem, JobMode, MotionType, RobotType


def homed(**fields) -> Harness:
    h = Harness(**fields)
    h.ok(Home(1))
    h.ok(Home(2))
    h.wait_model(2.1)
    return h


def codes(h: Harness) -> list[int]:
    return [a.code for a in h.ok(ReadAlarms())]


def running(h: Harness, channel: int = 1) -> bool:
    return h.ok(ReadStatus())[channel - 1].running


# -- speed -------------------------------------------------------------------------------------
def test_speed_reads_back_and_is_kept_per_channel():
    h = Harness()
    assert h.ok(ReadSpeed(1)) == 300
    h.ok(SetSpeed(1, 1000))
    h.ok(SetSpeed(2, 5))
    assert (h.ok(ReadSpeed(1)), h.ok(ReadSpeed(2))) == (1000, 5)
    assert h.raw(b"\xffCB01001") == Failure(0x31, "CB speed: 1001 is out of range 0..1000")


# -- servo (DB, two-phase) ---------------------------------------------------------------------
def test_db_answers_twice_and_the_second_comes_when_the_servo_is_on():
    h = Harness(speedup=0.5)
    start = h.now
    wait = h.ok(Servo(1, True))
    assert wait == 1  # 0.3 model s at half speed: under a second, not the manual's 2
    assert h.now - start == pytest.approx(0.6, abs=0.01)
    assert h.ok(ReadStatus())[0].servo_on
    assert h.controller.executions["DB"] == 1


def test_db_wait_is_never_more_than_the_manuals():
    h = Harness(speedup=0.1)
    assert h.ok(Servo(1, True)) == 2


def test_db_between_the_answers_the_servo_is_still_off():
    h = Harness(speedup=1.0)
    h.host.send_request(Servo(1, True).encode(), Servo.SHAPE, h.now)
    h.wait(0.1)
    assert not h.model.channel(1).servo
    h.wait(0.3)
    assert h.model.channel(1).servo


def test_an_alarm_during_servo_on_fails_the_second_answer():
    h = Harness(speedup=1.0)
    command = Servo(1, True)
    h.host.send_request(command.encode(), command.SHAPE, h.now)
    events, _ = h._pump()  # the request in, the first answer out
    packets = [e for e in events if isinstance(e, AnswerReceived)]
    h.model.raise_alarm(AlarmCode.TP_EMERGENCY, 1)
    for _ in range(100):
        events, moved = h._pump()
        packets += [e for e in events if isinstance(e, AnswerReceived)]
        if len(packets) == 2 or not (moved or h._step_clock()):
            break
    assert [p.flag for p in packets] == [0x30, 0x32]
    assert "alarm" in h.kd()
    assert not h.model.channel(1).servo


def test_servo_on_with_an_alarm_is_refused():
    h = Harness()
    h.model.raise_alarm(AlarmCode.TP_EMERGENCY, 1)
    assert "alarm" in h.fail(Servo(1, True))


def test_servo_off_stops_motion():
    h = homed()
    h.ok(Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((100.0, 100.0, 100.0, 0.0),)))
    h.ok(Servo(1, False))
    status = h.ok(ReadStatus())[0]
    assert not status.servo_on and not status.running


# -- jobs (DC, CC, CD, CE, EA, ED, EF) ---------------------------------------------------------
def test_dc_selects_the_job_after_its_load_time():
    h = homed()
    assert h.ok(ReadJobName(1)) is None
    assert h.ok(ReadJobStep(1)) == 0
    assert h.ok(SelectJob(1, "demo.job")) == 1
    assert h.ok(ReadJobName(1)) == FileName("DEMO", "JOB")
    assert h.ok(ReadJobStep(1)) == 1


def test_dc_before_origin_is_run_fail():
    h = Harness()
    assert "origin" in h.fail(SelectJob(1, "DEMO.JOB"))
    assert codes(h) == [AlarmCode.RUN_FAIL]


def test_dc_of_a_missing_file_or_a_pnt_name():
    h = homed()
    assert "no file NONE.JOB" in h.fail(SelectJob(1, "NONE.JOB"))
    assert codes(h) == []
    bad = h.raw(b"\xffDC0" + b"DEMO.PNT".rjust(12))
    assert isinstance(bad, Failure) and bad.flag == 0x31


def test_dc_of_a_job_with_a_syntax_error_raises_an_alarm():
    h = homed()
    h.ok(UploadFile(1, "BAD.JOB", 7, ["MAIN", "GOTO nowhere", "EOP"]))
    assert "BAD.JOB line 2" in h.fail(SelectJob(1, "BAD.JOB"))
    assert codes(h) == [AlarmCode.SYNTAX_ERROR]


def test_cc_runs_the_demo_job_to_its_end():
    h = homed()
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(StartJob(1))
    assert running(h)
    h.until(lambda: h.model.outputs[0][0])  # OUT 0,0,1 after the moves
    assert h.model.channel(1).joints == pytest.approx((0.0, 60.0, 50.0, 0.0))
    h.until(lambda: not running(h))
    assert h.ok(ReadOutputs(0)).contacts[0] is False  # OUT 0,0,0 before EOP
    assert h.model.channel(1).joints == pytest.approx((-30.0, 90.0, 100.0, 45.0))
    assert h.ok(ReadJobStep(1)) == 1
    assert codes(h) == []


def test_cc_needs_a_selected_job_origin_and_no_alarm():
    h = homed()
    assert "no job selected" in h.fail(StartJob(1))
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.model.raise_alarm(1153, 1)
    assert "alarm" in h.fail(StartJob(1))
    h.ok(ResetAlarms())
    h.ok(Servo(1, False))
    h.ok(Servo(2, False))
    h.ok(Restart())  # origin is lost
    assert "origin" in h.fail(StartJob(1))
    assert codes(h) == [AlarmCode.RUN_FAIL]


def test_cc_with_auto_servo_dis_needs_the_servo_on():
    h = Harness(auto_servo_on=False)
    h.ok(Servo(1, True))
    h.ok(Home(1))
    h.wait_model(2.1)
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(Servo(1, False))
    assert "servo off" in h.fail(StartJob(1))


def test_cd_holds_the_job_and_cc_resumes_it():
    h = homed()
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(StartJob(1))
    h.until(lambda: h.ok(ReadJobStep(1)) == 3)
    h.ok(StopJob(1))
    assert not running(h)
    step = h.ok(ReadJobStep(1))
    h.wait_model(5.0)
    assert h.ok(ReadJobStep(1)) == step
    h.ok(StartJob(1))
    h.until(lambda: not running(h))
    assert h.model.channel(1).joints == pytest.approx((-30.0, 90.0, 100.0, 45.0))
    h.ok(StopJob(1))  # stopping a stopped job is harmless


def test_job_step_mode_runs_one_step_per_cc():
    h = homed()
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(SetJobMode(1, JobMode.STEP))
    h.ok(StartJob(1))
    h.until(lambda: not running(h))
    assert h.ok(ReadJobStep(1)) == 2
    h.ok(StartJob(1))
    h.until(lambda: not running(h))
    assert h.ok(ReadJobStep(1)) == 3
    assert h.model.channel(1).joints == pytest.approx((30.0, 60.0, 50.0, 0.0))


def test_ea_only_while_the_run_bit_is_off():
    h = homed()
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(StartJob(1))
    assert "RUN bit" in h.fail(SetJobMode(1, JobMode.STEP))
    h.ok(StopJob(1))
    h.ok(SetJobMode(1, JobMode.STEP))


def test_ce_resets_to_main_only_with_the_servo_off():
    h = homed()
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(StartJob(1))
    h.until(lambda: h.ok(ReadJobStep(1)) == 3)
    h.ok(StopJob(1))
    assert "servo is on" in h.fail(ResetJob(1))
    h.ok(Servo(1, False))
    start = h.now
    assert h.ok(ResetJob(1)) is None
    assert h.now - start >= 0.2 / h.config.speedup
    assert h.ok(ReadJobStep(1)) == 1


def test_ce_without_a_job_is_refused():
    h = Harness()
    assert "no job selected" in h.fail(ResetJob(1))


def test_a_job_waits_for_an_input_and_sets_outputs():
    h = homed()
    h.ok(UploadFile(1, "IO.JOB", 9, ["MAIN", "WAIT IN 1,4,1", "OUT 2,15,1", "EOP"]))
    h.ok(SelectJob(1, "IO.JOB"))
    h.ok(StartJob(1))
    h.wait_model(5.0)
    assert running(h) and h.ok(ReadJobStep(1)) == 2
    h.model.set_input(1, 4, True)
    h.until(lambda: not running(h))
    assert h.ok(ReadOutputs(2)).contacts[15] is True


def test_a_job_move_to_a_missing_point_stops_with_run_fail():
    h = homed()
    h.ok(UploadFile(1, "DEMO.JOB", 1, ["MAIN", "JMOV P42", "EOP"]))
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(StartJob(1))
    h.until(lambda: not running(h))
    assert codes(h) == [AlarmCode.RUN_FAIL]
    assert h.ok(ReadJobStep(1)) == 2


def test_a_job_out_on_a_missing_port_stops_with_run_fail():
    h = homed(io_boards=(1, 0))
    h.ok(UploadFile(1, "OUTS.JOB", 3, ["MAIN", "OUT 1,0,1", "EOP"]))
    h.ok(SelectJob(1, "OUTS.JOB"))
    h.ok(StartJob(1))
    h.until(lambda: not running(h))
    assert codes(h) == [AlarmCode.RUN_FAIL]


def test_a_looping_job_runs_until_cd():
    h = homed()
    h.ok(UploadFile(1, "LOOP.JOB", 4, ["MAIN", "top:", "DELAY 100", "GOTO top"]))
    h.ok(SelectJob(1, "LOOP.JOB"))
    h.ok(StartJob(1))
    h.wait_model(30.0)
    assert running(h)
    h.ok(StopJob(1))
    assert not running(h)


# -- alarms and restart (CF, CG, CJ) -----------------------------------------------------------
def test_cf_is_a_host_emergency_that_stops_everything_and_cg_clears_it():
    h = homed()
    h.ok(Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((100.0, 100.0, 100.0, 0.0),)))
    h.ok(EmergencyStop())
    statuses = h.ok(ReadStatus())
    for status in statuses[:2]:
        assert status.alarm and not status.servo_on and not status.running
    assert codes(h) == [AlarmCode.HOST_EMERGENCY]
    stopped = h.model.channel(1).joints
    h.wait_model(5.0)
    assert h.model.channel(1).joints == stopped
    h.ok(ResetAlarms())
    assert codes(h) == []
    assert not any(s.alarm for s in h.ok(ReadStatus()))


def test_cj_needs_every_servo_off():
    h = homed()
    assert "servo is on" in h.fail(Restart())


def test_cj_resets_volatile_state_and_keeps_files_and_globals():
    h = homed()
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(SetJobMode(1, JobMode.STEP))
    h.ok(WriteGlobalInt(7, 1234))
    h.ok(SetSpeed(1, 777))
    h.model.raise_alarm(AlarmCode.TP_EMERGENCY, 9)  # servo off everywhere
    h.model.channel(1).joints = (10.0, 20.0, 30.0, 40.0)
    h.ok(Restart())
    assert h.model.channel(1).joints == (10.0, 20.0, 30.0, 40.0)
    status = h.ok(ReadStatus())[0]
    assert not status.origin and not status.alarm and not status.servo_on
    assert h.ok(ReadGlobalInt(7)) == 1234
    assert h.ok(ReadSpeed(1)) == 777
    assert h.ok(ReadJobName(1)) == FileName("DEMO", "JOB")
    assert h.model.channel(1).mode is JobMode.AUTO
    assert h.model.channel(1).files.get(FileName("DEMO", "PNT")) is not None


# -- reference axis (CX, CZ) -------------------------------------------------------------------
def test_cx_sets_the_reference_axis_with_the_servo_off_and_cz_reads_it():
    h = Harness()
    assert h.ok(ReadReferenceAxis(1)) == 1
    h.ok(SetReferenceAxis(1, 4))
    assert h.ok(ReadReferenceAxis(1)) == 4
    assert "axis 4" in h.fail(SetReferenceAxis(2, 4))  # a 2-axis robot has no W
    h.ok(Servo(1, True))
    assert "servo is on" in h.fail(SetReferenceAxis(1, 1))


def test_a_background_task_job_cannot_move():
    config = SimConfig(
        speedup=50.0,
        channels=(ChannelConfig(RobotType.XY, 2), ChannelConfig(RobotType.BACKGROUND_TASK, 1)),
    )
    h = Harness(config)
    h.model.channel(2).origin = True  # a BGT has nothing to home; jobs still need the flag
    h.ok(SelectJob(2, "DEMO.JOB"))
    h.ok(StartJob(2))
    h.until(lambda: not running(h, 2))
    assert h.model.outputs[0][0] is False and codes(h) == []  # the demo without its moves
    h.ok(UploadFile(2, "MOVE.JOB", 2, ["MAIN", "JMOV P1", "EOP"]))
    h.ok(SelectJob(2, "MOVE.JOB"))
    h.ok(StartJob(2))
    h.until(lambda: not running(h, 2))
    assert codes(h) == [AlarmCode.RUN_FAIL]
