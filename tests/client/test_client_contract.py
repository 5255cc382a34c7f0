"""The contract suite: every client method against the simulator, unchanged on every line.

Each test runs six times: in memory, over TCP and through a pseudo-terminal, with the blocking
client and with the asyncio client (behind a blocking bridge). ``test_every_method_is_covered``
keeps the suite honest: each public method of the command surface is called here.
"""

from __future__ import annotations

import ast
import inspect
import time
from pathlib import Path

import pytest

from robostar.client import AlarmRaisedError, Manifest, WaitTimeoutError
from robostar.client.binding import is_operation
from robostar.client.surface import Operations
from robostar.commands.status import ReadPosition, ReadStatus
from robostar.errors import FieldError, FunctionFailedError, UsageError
from robostar.protocol.fields import FileName
from robostar.types import (
    ArmForm,
    ChannelStatus,
    CoordSystem,
    FileRecord,
    JobFile,
    Point,
    PointFile,
    Position,
    PositionKind,
    RobotType,
)

from .conftest import Robot

pytestmark = pytest.mark.timeout(60)

JOB = ("MAIN", "JMOV P1", "DELAY 100", "EOP")


def close_to(actual: tuple[float, ...], expected: tuple[float, ...]) -> bool:
    return len(actual) == len(expected) and all(
        abs(a - e) < 1e-3 for a, e in zip(actual, expected, strict=True)
    )


# -- status ------------------------------------------------------------------------------------
def test_status_and_info(robot: Robot) -> None:
    status = robot.client.status()
    assert len(status) == 3 and all(isinstance(s, ChannelStatus) for s in status)
    assert status[0].ready and not status[0].running
    info = robot.client.info()
    assert info.max_channels == 2
    assert info.channel(1).robot_type is RobotType.SCARA
    assert info.channel(1).axes_in_use == (1, 2, 3, 4)
    assert robot.client.alarms() == ()


@pytest.mark.parametrize("kind", ["xy", "angle", "pulse", PositionKind.ANGLE])
def test_position_in_each_kind(robot: Robot, kind: str | PositionKind) -> None:
    position = robot.client.position(1, kind)
    assert isinstance(position, Position)
    assert position.kind.name.lower() == (kind if isinstance(kind, str) else kind.name.lower())
    assert len(position.axes) == 4


def test_execute_runs_any_command(robot: Robot) -> None:
    assert robot.client.execute(ReadStatus()) == robot.client.status()
    position = robot.client.execute(ReadPosition(2, PositionKind.ANGLE))
    assert position.kind is PositionKind.ANGLE and len(position.axes) == 2


# -- motion ------------------------------------------------------------------------------------
def test_home_with_wait_and_wait_homed(robot: Robot) -> None:
    robot.client.home(1, wait=True)
    assert robot.client.status()[0].origin
    assert robot.client.wait_homed(1, timeout=5).origin
    assert robot.controller.executions["BA"] == 1


def test_moves_reach_their_targets(robot: Robot) -> None:
    c = robot.client
    c.home(1, wait=True)
    c.move(1, (10, 20, 30, 0), wait=True)
    assert close_to(c.position(1, "angle").axes, (10, 20, 30, 0))
    c.move_by(1, (5, -5, 0, 0), wait=True)
    assert close_to(c.position(1, "angle").axes, (15, 15, 30, 0))
    c.move_to_point(1, "DEMO.PNT", 1, wait=True)
    assert close_to(c.position(1, "angle").axes, (30, 60, 50, 0))
    c.move_to_point(1, "DEMO.PNT", 3, via=2, wait=True)
    assert close_to(c.position(1, "angle").axes, (-30, 90, 100, 45))
    c.move_to_point(1, "DEMO", 1, motion="linear", wait=True)
    assert close_to(c.position(1, "angle").axes, (30, 60, 50, 0))
    c.move(1, (300, 100, 50, 0), coords="xy", motion="linear", wait=True)
    assert close_to(c.position(1, "xy").axes, (300, 100, 50, 0))
    c.move(1, (300, -100, 50, 0), coords=CoordSystem.XY, via=(350, 0, 50, 0), wait=True)
    assert close_to(c.position(1).axes, (300, -100, 50, 0))
    counts = robot.controller.executions
    assert (counts["BC"], counts["BD"], counts["BB"]) == (3, 1, 3)


def test_wait_stopped_after_a_move(robot: Robot) -> None:
    c = robot.client
    c.home(1, wait=True)
    c.set_speed(1, 10)
    c.move(1, (90, 0, 0, 0))
    assert c.status()[0].running
    status = c.wait_stopped(1, timeout=10)
    assert status.in_position and not status.running
    assert close_to(c.position(1, "angle").axes, (90, 0, 0, 0))


def test_wait_gives_up_after_its_timeout(robot: Robot) -> None:
    robot.client.home(1, wait=True)
    robot.client.set_speed(1, 1)
    robot.client.move(1, (120, 0, 0, 0))
    started = time.monotonic()
    with pytest.raises(WaitTimeoutError) as caught:
        robot.client.wait_stopped(1, timeout=0.1)
    assert time.monotonic() - started < 2
    assert caught.value.channel == 1 and caught.value.status is not None
    assert caught.value.status.running
    robot.client.stop_job(1)


def test_wait_reports_an_alarm(robot: Robot) -> None:
    robot.client.emergency_stop()
    with pytest.raises(AlarmRaisedError) as caught:
        robot.client.wait_homed(1, timeout=5)
    assert any(alarm.text == "Host Emergency" for alarm in caught.value.alarms)
    robot.client.reset_alarms()


def test_jog_moves_and_stops(robot: Robot) -> None:
    c = robot.client
    c.home(1, wait=True)
    before = c.position(1, "angle").axes[0]
    with c.jog(1, axis=1, direction="+", interval=0.05) as jog:
        time.sleep(0.3)
        assert c.status()[0].running
    assert jog.error is None
    counts = robot.controller.executions
    assert counts["BE"] == 1 and counts["BF"] >= 2 and counts["BG"] == 1
    assert c.position(1, "angle").axes[0] > before
    assert not c.status()[0].running


def test_jog_sends_bg_when_the_body_raises(robot: Robot) -> None:
    robot.client.home(1, wait=True)
    with pytest.raises(ZeroDivisionError), robot.client.jog(1, 2, "-"):
        _ = 1 / 0
    assert robot.controller.executions["BG"] == 1
    assert not robot.client.status()[0].running


def test_stop_homing(robot: Robot) -> None:
    robot.client.set_speed(1, 1)
    robot.client.home(1)
    robot.client.stop_homing(1)
    assert robot.controller.executions["CI"] == 1


# -- speed, jobs, servo ------------------------------------------------------------------------
def test_speed(robot: Robot) -> None:
    robot.client.set_speed(2, 500)
    assert robot.client.speed(2) == 500


HELD_JOB = ("MAIN", "WAIT IN 0,0,1", "EOP")
"""A job that runs until it is stopped: it waits for an input that nobody sets. (A job that ends
by itself, such as DEMO.JOB, may be over before the status read that follows its start: its
few model seconds are milliseconds at the suite's speedup, less than a loaded machine's pause.)"""


def test_job_control(robot: Robot) -> None:
    c = robot.client
    c.home(1, wait=True)
    c.upload_job(1, "HELD.JOB", HELD_JOB)
    assert c.select_job(1, "HELD.JOB") >= 0
    assert c.job_name(1) == FileName("HELD", "JOB")
    c.set_step_mode(1, True)
    c.set_step_mode(1, False)
    c.start_job(1)
    assert c.status()[0].running
    c.stop_job(1)
    assert c.job_step(1) >= 0
    assert c.servo(1, False) >= 0
    assert not c.status()[0].servo_on
    c.reset_job(1)
    c.servo(1, True)
    assert c.status()[0].servo_on
    counts = robot.controller.executions
    assert [counts[code] for code in ("DC", "EA", "CC", "CD", "DB", "CE")] == [1, 2, 1, 1, 2, 1]


def test_reference_axis_and_restart(robot: Robot) -> None:
    c = robot.client
    c.set_reference_axis(1, 4)
    assert c.reference_axis(1) == 4
    c.restart()
    assert robot.controller.executions["CJ"] == 1


def test_emergency_stop_and_alarms(robot: Robot) -> None:
    c = robot.client
    c.emergency_stop()
    assert [a.text for a in c.alarms()] == ["Host Emergency"]
    assert c.status()[0].alarm
    c.reset_alarms()
    assert c.alarms() == ()
    history = c.alarm_history()
    assert any(record.text == "Host Emergency" for record in history)


def test_function_failed_carries_the_controllers_reason(robot: Robot) -> None:
    with pytest.raises(FunctionFailedError) as caught:
        robot.client.start_job(1)
    assert caught.value.command == "CC"
    assert caught.value.reason and "job" in caught.value.reason
    assert robot.client.last_error() == caught.value.reason


# -- files -------------------------------------------------------------------------------------
def test_file_housekeeping(robot: Robot) -> None:
    c = robot.client
    assert c.file_exists(1, "DEMO.JOB")
    assert not c.file_exists(1, "NONE.JOB")
    names = [record.name for record in c.list_files(1)]
    assert names == ["DEMO.JOB", "DEMO.PNT"]
    assert c.list_files(1, "DEMO.JOB") == (FileRecord(1, "DEMO.JOB", 1, 8),)
    c.copy_file(1, "DEMO.JOB", "COPY.JOB")
    c.rename_file(1, "COPY.JOB", "REN.JOB")
    assert c.file_exists(1, "REN.JOB") and not c.file_exists(1, "COPY.JOB")
    c.delete_file(1, "REN.JOB")
    assert not c.file_exists(1, "REN.JOB")


def test_upload_and_download_with_progress(robot: Robot) -> None:
    c = robot.client
    sent: list[tuple[int, int | None]] = []
    c.upload_job(1, "NEW.JOB", JOB, progress=lambda done, total: sent.append((done, total)))
    assert sent == [(1, 4), (2, 4), (3, 4), (4, 4)]
    got: list[tuple[int, int | None]] = []
    job = c.download_job(1, "NEW", progress=lambda done, total: got.append((done, total)))
    assert job == JobFile(JOB)
    assert got[-1] == (6, 6) and len(got) == 6
    assert c.list_files(1, "NEW.JOB")[0].job_number == 2  # the lowest free JOB number

    points = {7: Point((1.0, 2.0, 3.0, 4.0), ArmForm.LEFT), 9: Point((5.5, 0.0, 0.0, 0.0))}
    c.upload_points(1, "NEW.PNT", points, number=3)
    assert c.download_points(1, "NEW.PNT") == PointFile(points)
    xy = c.download_points(1, "DEMO.PNT", coords="xy")
    assert sorted(xy.points) == [1, 2, 3]


def test_upload_replaces_a_file_under_its_own_number(robot: Robot) -> None:
    robot.client.upload_job(1, "DEMO.JOB", JOB)
    assert robot.client.download_job(1, "DEMO.JOB").lines == JOB
    assert robot.client.list_files(1, "DEMO.JOB")[0].job_number == 1


def test_backup_and_restore(robot: Robot, tmp_path: Path) -> None:
    c = robot.client
    c.upload_job(2, "TWO.JOB", JOB)
    manifest = c.backup(tmp_path / "backup")
    assert isinstance(manifest, Manifest)
    assert sorted((f.channel, f.name) for f in manifest.files) == [
        (1, "DEMO.JOB"),
        (1, "DEMO.PNT"),
        (2, "DEMO.JOB"),
        (2, "DEMO.PNT"),
        (2, "TWO.JOB"),
    ]
    assert (tmp_path / "backup" / "ch2" / "TWO.JOB").read_text() == "\n".join(JOB) + "\n"
    assert manifest.controller.name == c.info().name

    c.upload_job(1, "DEMO.JOB", ["MAIN", "EOP"])
    c.delete_file(2, "TWO.JOB")
    steps: list[tuple[int, int | None]] = []
    restored = c.restore(tmp_path / "backup", progress=lambda d, t: steps.append((d, t)))
    assert restored == manifest
    assert steps[-1] == (4, 4)  # only the changed DEMO.JOB and the new TWO.JOB are written
    assert c.download_job(2, "TWO.JOB").lines == JOB
    assert c.download_job(1, "DEMO.JOB").lines[1] == "JMOV P1"


# -- I/O and variables -------------------------------------------------------------------------
def test_io(robot: Robot) -> None:
    c = robot.client
    assert c.io_boards() == (1, 1)
    c.set_output(0, 3, True)
    assert c.outputs(0).on == (3,)
    with robot.touch():
        robot.controller.model.set_input(1, 15, True)
    assert c.inputs(1)[15] and c.inputs(0).on == ()


def test_global_variables(robot: Robot) -> None:
    c = robot.client
    c.write_global_int(7, -42)
    assert c.read_global_int(7) == -42
    c.write_global_float(499, 3.25)
    assert c.read_global_float(499) == 3.25
    c.write_global_point(1, 1023, (1.5, 2, 3, 4))
    assert c.read_global_point(1, 1023).axes[:4] == (1.5, 2.0, 3.0, 4.0)
    c.write_global_point(2, 0, Point((7.0, 8.0)), coords="angle")
    assert c.read_global_point(2, 0, axis=2).axes == (8.0,)


def test_parameters(robot: Robot) -> None:
    assert robot.client.parameters(1)[0].startswith("CONF")
    assert robot.client.parameters(None)
    assert robot.client.parameters(2, index=1)


# -- bad arguments are refused before anything is sent -------------------------------------------
@pytest.mark.parametrize(
    ("method", "args", "kwargs", "names"),
    [
        ("position", (4,), {}, "channel"),
        ("position", (1,), {"kind": "polar"}, "kind"),
        ("home", (0,), {}, "channel"),
        ("home", (1,), {"wait": "yes"}, "wait"),
        ("move", (1, (1, 2, 3, 4, 5, 6, 7)), {}, "target"),
        ("move", (1, "12"), {}, "target"),
        ("move", (1, (1, 2)), {"coords": "cylindrical"}, "coords"),
        ("move", (1, (1, 2)), {"motion": "arc"}, "via"),
        ("move", (1, (1, 2)), {"via": (0, 0), "motion": "joint"}, "via"),
        ("move", (1, (float("nan"), 2)), {}, "target axis 1"),
        ("move", (1, (1e12, 2)), {}, "target axis 1"),
        ("move", (1, (1, 2)), {"timeout": -1}, "timeout"),
        ("home", (1,), {"timeout": float("nan")}, "timeout"),
        ("move_by", (1, (1, 2)), {"motion": "arc"}, "motion"),
        ("move_to_point", (1, "TOOLONG.PNT", 1), {}, "file"),
        ("move_to_point", (1, "DEMO.JOB", 1), {}, "file"),
        ("move_to_point", (1, "DEMO.PNT", 10000), {}, "point"),
        ("set_speed", (1, 1001), {}, "speed"),
        ("set_speed", (1, "fast"), {}, "speed"),
        ("servo", (1, 1), {}, "on"),
        ("select_job", (1, "Demo.JOB"), {}, "name"),
        ("set_step_mode", (1, None), {}, "step"),
        ("set_reference_axis", (1, 2), {}, "axis"),
        ("upload_job", (1, "NEW.JOB", ["MAIN", "x" * 100]), {}, "line 2"),
        ("upload_job", (1, "NEW.JOB", "MAIN"), {}, "lines"),
        ("upload_job", (1, "NEW.JOB", ["MAIN"]), {"number": 201}, "number"),
        ("download_points", (1, "DEMO.JOB"), {}, "name"),
        ("list_files", (1, "A*.JOB"), {}, "pattern"),
        ("copy_file", (1, "DEMO.JOB", "C.JOB"), {"to_channel": 5}, "to_channel"),
        ("inputs", (5,), {}, "port"),
        ("set_output", (0, 16, True), {}, "contact"),
        ("set_output", (0, 1, "on"), {}, "on"),
        ("read_global_int", (500,), {}, "index"),
        ("write_global_float", (1, 1e12), {}, "value"),
        ("read_global_point", (1, 1024), {}, "index"),
        ("parameters", (1,), {"index": 0}, "index"),
        ("wait_stopped", (1,), {"timeout": 0}, "timeout"),
        ("execute", ("AA",), {}, "command"),
        ("backup", (42,), {}, "folder"),
    ],
)
def test_bad_arguments_are_refused_before_sending(
    robot: Robot, method: str, args: tuple[object, ...], kwargs: dict[str, object], names: str
) -> None:
    before = robot.controller.requests
    with pytest.raises(UsageError) as caught:
        getattr(robot.client, method)(*args, **kwargs)
    assert names in str(caught.value)
    if isinstance(caught.value, FieldError):
        assert caught.value.field == names
    assert robot.controller.requests == before


def test_bad_jog_arguments_are_refused_before_sending(robot: Robot) -> None:
    before = robot.controller.requests
    cases: list[tuple[tuple[object, ...], dict[str, object], str]] = [
        ((1, 7, "+"), {}, "axis"),
        ((1, 1, "up"), {}, "direction"),
        ((1, 1, "+"), {"motion": "arc"}, "motion"),
        ((1, 1, "+"), {"interval": 0.5}, "interval"),
    ]
    for args, kwargs, name in cases:
        with pytest.raises(UsageError, match=name):
            robot.client.jog(*args, **kwargs)
    assert robot.controller.requests == before


# -- the suite covers the surface -----------------------------------------------------------------
def test_every_method_is_covered() -> None:
    surface = {name for name, value in vars(Operations).items() if is_operation(value)} | {"jog"}
    tree = ast.parse(inspect.getsource(inspect.getmodule(test_every_method_is_covered)))  # type: ignore[arg-type]
    called = {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)} | {
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, str)
    }
    assert sorted(surface - called) == []
    assert len(surface) >= 50
