"""Reading commands against the simulator, in --json mode and for a person."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from click.testing import Result

from .conftest import SIM

Run = Callable[..., Result]
AsJson = Callable[[Result], Any]


def test_status(run: Run, as_json: AsJson) -> None:
    data = as_json(run("--json", "status"))
    assert [c["channel"] for c in data["channels"]] == [1, 2, 3]
    assert data["channels"][0]["servo_on"] is False
    assert data["channels"][0]["ready"] is True
    human = run("status")
    assert human.exit_code == 0
    assert "servo on" in human.stdout and "in position" in human.stdout
    assert "○ off" in human.stdout


def test_info(run: Run, as_json: AsJson) -> None:
    data = as_json(run("info", "--json"))
    assert data["name"] == "N1-SIM"
    assert data["channels"][0]["model"] == "RSA60A"
    assert data["channels"][0]["robot_type"] == "scara"
    human = run("info").stdout
    assert "N1-SIM" in human and "RSA60A" in human and "scara" in human


def test_alarms_and_history(run: Run, as_json: AsJson) -> None:
    assert as_json(run("--json", "alarms")) == {"alarms": [], "simulator": True, "url": SIM}
    assert "No alarms." in run("alarms").stdout
    assert as_json(run("--json", "alarms", "--history")) == {
        "history": [],
        "simulator": True,
        "url": SIM,
    }
    assert "empty" in run("alarms", "--history").stdout


@pytest.mark.parametrize("kind", ["pulse", "angle", "xy"])
def test_position_kinds(run: Run, as_json: AsJson, kind: str) -> None:
    data = as_json(run("--json", "position", "--kind", kind))
    assert data["channel"] == 1
    assert data["kind"] == kind
    assert len(data["axes"]) == 4
    human = run("position", "--kind", kind).stdout
    assert f"Channel 1 position ({kind})" in human
    assert "axis 4" in human


def test_position_of_channel_two(run: Run, as_json: AsJson) -> None:
    data = as_json(run("--channel", "2", "--json", "position"))
    assert data["channel"] == 2
    assert len(data["axes"]) == 2
    after = as_json(run("position", "-c", "2", "--json"))
    assert after["channel"] == 2


def test_speed_and_job(run: Run, as_json: AsJson) -> None:
    speed = as_json(run("--json", "speed"))
    assert 0 <= speed["speed"] <= 1000
    assert speed["percent"] == speed["speed"] / 10
    assert "% of Mv" in run("speed").stdout
    job = as_json(run("--json", "job"))
    assert job == {
        "channel": 1,
        "job": None,
        "step": 0,
        "running": False,
        "simulator": True,
        "url": SIM,
    }
    assert "(none selected)" in run("job").stdout


def test_io_reads(run: Run, as_json: AsJson) -> None:
    inputs = as_json(run("--json", "io", "in", "0"))
    assert inputs["kind"] == "in" and inputs["port"] == 0
    assert inputs["contacts"] == [False] * 16
    outputs = as_json(run("io", "out", "0", "--json"))
    assert outputs["on"] == []
    assert "out 0" in run("io", "out", "0").stdout
    assert as_json(run("--json", "io", "boards")) == {
        "input_boards": 1,
        "output_boards": 1,
        "simulator": True,
        "url": SIM,
    }
    assert "1 input, 1 output" in run("io", "boards").stdout


def test_globals_read(run: Run, as_json: AsJson) -> None:
    assert as_json(run("--json", "global", "get", "int", "5")) == {
        "kind": "int",
        "index": 5,
        "value": 0,
        "simulator": True,
        "url": SIM,
    }
    assert as_json(run("--json", "global", "get", "float", "499"))["value"] == 0.0
    point = as_json(run("--json", "global", "get", "point", "1023", "--xy"))
    assert point["coords"] == "xy"
    assert point["point"]["used"] is False  # a fresh controller holds no global points
    assert "Global int 5 = 0" in run("global", "get", "int", "5").stdout
    assert "Global point 3" in run("global", "get", "point", "3").stdout


def test_params_and_last_error(run: Run, as_json: AsJson) -> None:
    data = as_json(run("--json", "params", "--index", "1"))
    assert data["channel"] == 1 and data["parameters"]
    public = as_json(run("--json", "params", "--public"))
    assert public["channel"] is None and public["parameters"]
    assert "Channel 1 parameters" in run("params").stdout
    error = as_json(run("--json", "last-error"))
    assert isinstance(error["last_error"], str)
    assert run("last-error").exit_code == 0


def test_ref_axis_read(run: Run, as_json: AsJson) -> None:
    assert as_json(run("--json", "ref-axis")) == {
        "channel": 1,
        "reference_axis": 1,
        "simulator": True,
        "url": SIM,
    }
    assert "reference axis: 1 (X)" in run("ref-axis").stdout


def test_monitor_once(run: Run, as_json: AsJson) -> None:
    data = as_json(run("--json", "monitor", "--count", "1", "--ports", "0"))
    assert data["line_ok"] is True
    assert [c["channel"] for c in data["channels"]] == [1, 2]
    assert data["inputs"] == {"0": [0] * 16}
    human = run("monitor", "--count", "1").stdout
    assert "line OK" in human and "RSA60A" in human and "alarms: none" in human


def test_monitor_lines_are_json_lines(run: Run) -> None:
    result = run("--json", "monitor", "--count", "2", "--rate", "20")
    assert result.exit_code == 0
    lines = result.stdout.strip().splitlines()
    assert len(lines) == 2
