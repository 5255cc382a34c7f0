"""Commands that act on the controller, against one simulator served for the whole test."""

from __future__ import annotations

import json
from typing import Any

import pytest

from .conftest import AsJson, Run


def homed(on: Run) -> None:
    assert on("servo", "on").exit_code == 0
    assert on("home").exit_code == 0


def test_servo_on_and_off(on: Run, as_json: AsJson) -> None:
    data = as_json(on("--json", "servo", "on"))
    assert data["ok"] is True and data["servo_on"] is True
    assert as_json(on("--json", "status"))["channels"][0]["servo_on"] is True
    human = on("servo", "off")
    assert human.exit_code == 0
    assert "Channel 1 servo is off." in human.stdout


def test_home_says_it_moves_then_reports_the_position(on: Run, as_json: AsJson) -> None:
    human = on("home")
    assert human.exit_code == 0
    assert "homing: the robot moves to its origin" in human.stderr
    assert "Motion done." in human.stdout
    data = as_json(on("--json", "home"))
    assert data["homed"] is True and data["position"]["kind"] == "xy"
    assert as_json(on("--json", "status"))["channels"][0]["origin"] is True
    stop = as_json(on("--json", "home", "--stop"))
    assert stop["homing"] == "stopped"


def test_move_absolute_relative_and_xy(on: Run, as_json: AsJson) -> None:
    homed(on)
    human = on("move", "10", "20", "30", "0")
    assert human.exit_code == 0, human.output
    assert "Channel 1 will move (joint, angle coordinates) to (10, 20, 30, 0)." in human.stderr
    angles = as_json(on("--json", "position", "--kind", "angle"))["axes"]
    assert angles == pytest.approx([10, 20, 30, 0], abs=0.01)

    data = as_json(on("--json", "move", "--by", "-5", "0", "0", "0"))
    assert data["relative"] is True and data["waited"] is True
    angles = as_json(on("--json", "position", "--kind", "angle"))["axes"]
    assert angles[0] == pytest.approx(5, abs=0.01)

    xy = as_json(on("--json", "position"))["axes"]
    target = [round(xy[0] - 20, 3), round(xy[1] + 10, 3), 30, 0]
    data = as_json(on("--json", "move", "--xy", "--linear", *map(str, target)))
    assert data["coords"] == "xy" and data["motion"] == "linear"
    assert data["position"]["axes"][:2] == pytest.approx(target[:2], abs=0.05)


def test_move_along_an_arc(on: Run, as_json: AsJson) -> None:
    homed(on)
    on("move", "0", "60", "50", "0")
    xy = as_json(on("--json", "position"))["axes"]
    via = f"{xy[0] - 20:.3f},{xy[1] + 20:.3f},50,0"
    target = [f"{xy[0] - 40:.3f}", f"{xy[1]:.3f}", "50", "0"]
    data = as_json(on("--json", "move", "--arc", "--xy", "--via", via, *target))
    assert data["motion"] == "arc"
    assert data["position"]["axes"][0] == pytest.approx(float(target[0]), abs=0.1)


def test_move_without_wait_returns_at_once(on: Run, as_json: AsJson) -> None:
    homed(on)
    data = as_json(on("--json", "move", "--no-wait", "5", "5", "5", "5"))
    assert data["waited"] is False
    assert "Motion started." in on("move", "--no-wait", "6", "6", "6", "6").stdout


def test_move_point(on: Run, as_json: AsJson) -> None:
    homed(on)
    data = as_json(on("--json", "move-point", "DEMO.PNT", "2"))
    assert data["file"] == "DEMO.PNT" and data["point"] == 2
    angles = as_json(on("--json", "position", "--kind", "angle"))["axes"]
    assert angles[:3] == pytest.approx([0, 60, 50], abs=0.01)
    human = on("move-point", "DEMO.PNT", "1")
    assert "to point 1 of DEMO.PNT" in human.stderr
    assert human.exit_code == 0


def test_refused_motion_reads_the_reason_and_exits_3(on: Run) -> None:
    human = on("move", "10", "20", "30", "0")
    assert human.exit_code == 3
    assert "The move was refused by the controller" in human.stderr
    assert "Protocol: BC" in human.stderr  # the code is in the detail line
    assert "robostar home" in human.stderr
    result = on("--json", "move", "10", "20", "30", "0")
    assert result.exit_code == 3
    error = json.loads(result.stderr.splitlines()[-1])["error"]
    assert error["type"] == "FunctionFailedError"
    assert error["command"] == "BC"
    assert error["reason"]


def test_soft_limit_is_refused(on: Run) -> None:
    homed(on)
    result = on("move", "500", "0", "0", "0")
    assert result.exit_code == 3
    assert "soft limits" in result.stderr


def test_speed_set(on: Run, as_json: AsJson) -> None:
    assert as_json(on("--json", "speed", "set", "250"))["speed"] == 250
    assert as_json(on("--json", "speed"))["speed"] == 250
    assert "set to 400 (40 % of Mv)" in on("speed", "set", "400").stdout
    assert on("speed", "set", "1001").exit_code == 2


def test_job_lifecycle(on: Run, as_json: AsJson) -> None:
    homed(on)
    assert as_json(on("--json", "job", "select", "DEMO.JOB"))["job"] == "DEMO.JOB"
    assert as_json(on("--json", "job"))["job"] == "DEMO.JOB"
    assert as_json(on("--json", "job", "mode", "step"))["mode"] == "step"
    started = on("job", "start")
    assert started.exit_code == 0
    assert "the robot will move" in started.stderr
    assert as_json(on("--json", "job", "stop"))["running"] is False
    assert "auto" in on("job", "mode", "auto").stdout
    assert on("servo", "off").exit_code == 0
    reset = on("job", "reset")
    assert reset.exit_code == 0, reset.output
    assert "first step" in reset.stdout
    assert as_json(on("--json", "job", "select", "DEMO.JOB", "-c", "1"))["channel"] == 1


def test_io_set(on: Run, as_json: AsJson, sim_line: Any) -> None:
    data = as_json(on("--json", "io", "set", "0", "3", "on"))
    assert data == {
        "ok": True,
        "port": 0,
        "contact": 3,
        "on": True,
        "simulator": True,
        "url": sim_line.url,
    }
    assert as_json(on("--json", "io", "out", "0"))["on"] == [3]
    assert "Output 0.3 is off." in on("io", "set", "0", "3", "off").stdout
    sim_line.set_input(0, 15, True)
    assert as_json(on("--json", "io", "in", "0"))["on"] == [15]
    assert on("io", "set", "0", "16", "on").exit_code == 2


def test_globals_write(on: Run, as_json: AsJson) -> None:
    assert as_json(on("--json", "global", "set", "int", "7", "-42"))["value"] == -42
    assert as_json(on("--json", "global", "get", "int", "7"))["value"] == -42
    assert "Global float 3 = -1.25." in on("global", "set", "float", "3", "-1.25").stdout
    assert as_json(on("--json", "global", "get", "float", "3"))["value"] == -1.25
    written = as_json(on("--json", "global", "set", "point", "10", "1", "-2", "3", "4"))
    assert written["point"]["axes"] == [1, -2, 3, 4]
    read = as_json(on("--json", "global", "get", "point", "10"))
    assert read["point"]["axes"][:4] == [1, -2, 3, 4]
    assert on("global", "set", "point", "10", "7.5", "--axis", "3").exit_code == 0
    one = as_json(on("--json", "global", "get", "point", "10", "--axis", "3"))
    assert one["point"]["axes"] == [7.5]
    assert on("global", "set", "int", "500", "1").exit_code == 2
    assert on("global", "set", "int", "5", "x").exit_code == 2


def test_estop_reset_restart_and_ref_axis(on: Run, as_json: AsJson) -> None:
    assert "Emergency stop sent." in on("estop").stdout
    alarms = as_json(on("--json", "alarms"))["alarms"]
    assert any("Emergency" in a["text"] for a in alarms)
    history = as_json(on("--json", "alarms", "--history"))["history"]
    assert history
    assert "Alarm history" in on("alarms", "--history").stdout
    assert as_json(on("--json", "reset"))["reset"] is True
    assert as_json(on("--json", "alarms"))["alarms"] == []
    assert as_json(on("--json", "ref-axis", "4"))["reference_axis"] == 4
    assert as_json(on("--json", "ref-axis"))["reference_axis"] == 4
    assert "reference axis set to 1" in on("ref-axis", "1").stdout
    assert as_json(on("--json", "restart"))["restart"] is True
    assert "restarting" in on("restart").stdout


def test_timed_jog(on: Run, as_json: AsJson) -> None:
    data = as_json(
        on("--json", "jog", "--axis", "1", "--direction", "+", "--for", "0.3", "--speed", "50")
    )
    assert data["axis"] == 1 and data["direction"] == "+"
    assert data["position"]["axes"][0] > 0
    human = on("jog", "--axis", "2", "--direction", "minus", "--for", "0.2")
    assert human.exit_code == 0
    assert "will jog - for 0.2 s" in human.stderr
    assert "Jogged axis 2 -" in human.stdout


def test_jog_pad_needs_a_terminal(on: Run) -> None:
    result = on("jog")
    assert result.exit_code == 2
    assert "needs a terminal" in result.stderr
    assert on("jog", "--for", "1").exit_code == 2


def test_dry_run_sends_nothing(on: Run, as_json: AsJson, sim_line: Any) -> None:
    before = dict(sim_line.controller.executions)
    data = as_json(on("--json", "--dry-run", "move", "--xy", "1", "2", "3", "4"))
    assert data["dry_run"] is True
    (frame,) = data["frames"]
    assert frame["hex"].startswith("02 ff 42 43")  # STX FF 'B' 'C'
    assert "BC Move" in frame["meaning"]
    human = on("--dry-run", "home")
    assert human.exit_code == 0
    assert "Nothing was sent." in human.stdout
    assert "homing" not in human.stderr
    jog = as_json(on("--json", "--dry-run", "jog", "--direction", "+", "--for", "1"))
    assert [f["meaning"].split()[0] for f in jog["frames"]] == ["BE", "BF", "BG"]
    for args in (
        ["servo", "on"],
        ["io", "set", "0", "1", "on"],
        ["global", "set", "int", "1", "2"],
        ["job", "start"],
        ["estop"],
        ["files", "rm", "DEMO.JOB"],
    ):
        assert on("--dry-run", *args).exit_code == 0, args
    assert dict(sim_line.controller.executions) == before
