"""Polish users hit: 80 columns, globs, the default TCP port, doctor's port list, sim alarms."""

from __future__ import annotations

import json
import threading
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from click.testing import CliRunner, Result
from rich.cells import cell_len

from robostar.cli import cli
from robostar.sim import SimConfig
from robostar.sim.listeners import serve

Run = Callable[..., Result]
AsJson = Callable[[Result], Any]


def test_monitor_fits_80_columns() -> None:
    result = CliRunner(env={"COLUMNS": "80"}).invoke(
        cli, ["--port", "sim://", "monitor", "--count", "1", "--channels", "1,2"]
    )
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines and max(cell_len(line) for line in lines) <= 80
    rows = [line for line in lines if "RSA60A" in line or " XY " in line]
    assert len(rows) == 2 and not any("…" in row for row in rows)
    assert "600.0 0.0 0.0 0.0" in rows[0]


def test_files_ls_takes_globs(run: Run, as_json: AsJson) -> None:
    def names(pattern: str) -> list[str]:
        return [f["name"] for f in as_json(run("--json", "files", "ls", pattern))["files"]]

    assert names("*.PNT") == ["DEMO.PNT"]
    assert names("d*") == ["DEMO.JOB", "DEMO.PNT"]
    assert names("DEMO.?OB") == ["DEMO.JOB"]
    assert names("X*") == []
    assert names("DEMO.JOB") == ["DEMO.JOB"]


def test_tcp_without_port_says_the_default(run: Run) -> None:
    result = run("status", port="tcp://127.0.0.1")
    assert result.exit_code == 4
    assert "tcp://127.0.0.1 (default port 20000)" in result.stderr


def test_doctor_lists_serial_ports_and_what_it_tried(run: Run, as_json: AsJson) -> None:
    data = as_json(run("--json", "doctor", "--count", "1"))
    checks = {c["name"]: c for c in data["checks"]}
    assert "serial ports" in checks and checks["serial ports"]["detail"]
    assert "answers AA" in data["tried"]
    no_target = run("doctor", port=None)
    assert no_target.exit_code == 2
    assert "Serial ports here:" in no_target.stdout and "--port" in no_target.stderr


@pytest.fixture
def served() -> Iterator[tuple[str, str]]:
    ready = threading.Event()
    endpoints: list[str] = []
    stop = threading.Event()

    def on_ready(found: list[str]) -> None:
        endpoints.extend(found)
        ready.set()

    thread = threading.Thread(
        target=serve,
        args=(SimConfig(),),
        kwargs={
            "listen": "127.0.0.1:0",
            "control": "127.0.0.1:0",
            "on_ready": on_ready,
            "stop": stop,
        },
        daemon=True,
    )
    thread.start()
    assert ready.wait(10)
    tcp = next(e for e in endpoints if e.startswith("tcp://"))
    control = next(e for e in endpoints if e.startswith("control://")).removeprefix("control://")
    yield tcp, control
    stop.set()
    thread.join(10)


def test_sim_alarm_raise_and_clear(run: Run, as_json: AsJson, served: tuple[str, str]) -> None:
    tcp, control = served
    raised = run("sim", "alarm", "raise", "1153", "--channel", "1", "--control", control, port=None)
    assert raised.exit_code == 0, raised.output
    assert "SIMULATOR" in raised.stdout
    alarms = as_json(run("--json", "alarms", port=tcp))["alarms"]
    assert [a["code"] for a in alarms] == [1153]
    cleared = run("sim", "alarm", "clear", port=tcp)
    assert cleared.exit_code == 0, cleared.output
    assert as_json(run("--json", "alarms", port=tcp))["alarms"] == []
    bad = run("sim", "alarm", "raise", "1", "--control", "127.0.0.1:9", port=None)
    assert bad.exit_code == 2 and "control socket" in bad.stderr
    unknown = run("sim", "alarm", "raise", "1", "--control", control, port=None)  # no such code
    assert unknown.exit_code == 2 and "simulator refused: alarm code 1" in unknown.stderr
    assert json.loads(run("--json", "sim", "alarm", "raise", "12345", port=None).stderr)
