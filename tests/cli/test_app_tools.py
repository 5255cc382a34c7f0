"""Engineering tools (raw, doctor, sim, demo), help texts, exit codes and the wire trace."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
import pytest
from click.testing import CliRunner, Result

from robostar.cli import cli
from robostar.cli.app import SUBCOMMANDS
from robostar.cli.raw import build_raw, parse_params
from robostar.errors import UsageError

Run = Callable[..., Result]
AsJson = Callable[[Result], Any]


# -- raw ---------------------------------------------------------------------------------------
def test_raw_sends_and_decodes(run: Run, as_json: AsJson) -> None:
    data = as_json(run("--json", "raw", "AC", "0", "1"))
    assert data["request"]["hex"] == "02 ff 41 43 30 31 03 fc"
    assert data["answer"][0]["flag"] == "OK"
    assert data["result"]["kind"] == "angle"
    human = run("raw", "AA").stdout
    assert "decoded:" in human and "sent  02 ff 41 41 03 ff" in human


def test_raw_refusal_and_unknown_command(run: Run, as_json: AsJson) -> None:
    refused = run("raw", "BC", "0", "0", "0", "     1.000")
    assert refused.exit_code == 3
    assert "Protocol: BC" in refused.stderr
    assert "may move" in refused.stderr
    unknown = run("--dry-run", "raw", "ZZ", "0x3031")
    assert unknown.exit_code == 0
    assert "not in the manual's command list" in unknown.stderr
    assert run("raw", "FB").exit_code == 2
    assert run("raw", "A1").exit_code == 2


def test_raw_parameters() -> None:
    assert parse_params(["0", "0x3132", "AB"]) == b"012AB"
    with pytest.raises(UsageError):
        parse_params(["0x123"])
    command, warning = build_raw("ac", b"02", None)
    assert command.CODE == "AC" and not warning and command.typed is not None
    command, warning = build_raw("AC", b"9", None)
    assert command.typed is None and "do not decode" in warning
    with pytest.raises(UsageError):
        build_raw("AB", b"", "single")


# -- doctor ------------------------------------------------------------------------------------
def test_doctor_on_the_simulator(run: Run, as_json: AsJson) -> None:
    data = as_json(run("--json", "doctor", "--count", "3"))
    assert data["ok"] is True
    checks = {c["name"]: c for c in data["checks"]}
    assert checks["baud rate"]["ok"] is None
    assert checks["answers AA"]["ok"] is True
    assert "3 x AA" in checks["round trip"]["detail"]
    assert "N1-SIM" in checks["controller"]["detail"]
    assert "All good." in run("doctor").stdout


def test_doctor_over_a_serial_line() -> None:
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.listeners import PeerHost

    host = PeerHost(VirtualController(SimConfig(speedup=50)))
    device = host.open_pty()
    host.start()
    try:
        result = CliRunner().invoke(cli, ["--port", device, "--json", "doctor", "--count", "2"])
    finally:
        host.close()
    assert result.exit_code == 0, result.output
    checks = {c["name"]: c for c in json.loads(result.stdout)["checks"]}
    assert checks["baud rate"]["ok"] is True
    assert "115200" in checks["baud rate"]["detail"]


def test_doctor_reports_a_dead_port(run: Run) -> None:
    result = run("--json", "doctor", port="tcp://127.0.0.1:1")
    assert result.exit_code == 4
    data = json.loads(result.stdout)
    assert data["ok"] is False
    assert data["checks"][-1]["name"] == "port"
    human = run("doctor", port="tcp://127.0.0.1:1")
    assert "✗ port" in human.stdout and "Something is wrong" in human.stdout


# -- exit codes and sentences ------------------------------------------------------------------
def test_line_failure_exits_4_with_a_sentence(run: Run) -> None:
    result = run("status", port="tcp://127.0.0.1:1")
    assert result.exit_code == 4
    assert result.stderr.startswith("Error: tcp://127.0.0.1:1")
    assert "--port" in result.stderr
    as_json = run("--json", "status", port="tcp://127.0.0.1:1")
    error = json.loads(as_json.stderr)["error"]
    assert error["exit_code"] == 4 and error["type"] == "PortError"


def test_timeout_exits_4(run: Run, sim_line: Any) -> None:
    sim_line.host.close()
    result = run("--timeout", "0.2", "status", port=sim_line.url)
    assert result.exit_code == 4


def test_bad_arguments_exit_2(run: Run) -> None:
    assert run("--channel", "4", "status").exit_code == 2
    assert run("position", "--kind", "polar").exit_code == 2
    assert run("servo", "maybe").exit_code == 2
    bad_name = run("files", "rm", "TOOLONGNAME.JOB")
    assert bad_name.exit_code == 2
    assert "Nothing was sent." in bad_name.stderr
    assert run("move", "1", "x").exit_code == 2
    assert run("move", "--by", "--arc", "--via", "1,2", "1", "2").exit_code == 2
    assert run("move-point", "DEMO.PNT", "3", "--arc").exit_code == 2


def test_trace_file_decodes(run: Run, as_json: AsJson, tmp_path: Path) -> None:
    trace = tmp_path / "wire.jsonl"
    assert run("--trace", str(trace), "position").exit_code == 0
    frames = as_json(run("--json", "decode", str(trace), port=None))["frames"]
    requests = [f for f in frames if f["kind"] == "request"]
    assert requests[-1]["command"] == "AC"
    assert any(f.get("fields", {}).get("result", {}).get("kind") == "xy" for f in frames)


# -- help ----------------------------------------------------------------------------------------
def _all_commands() -> list[list[str]]:
    paths: list[list[str]] = [[]]
    context = click.Context(cli)
    for name in SUBCOMMANDS:
        command = cli.get_command(context, name)
        paths.append([name])
        if isinstance(command, click.Group):
            paths += [[name, sub] for sub in command.list_commands(context)]
    return paths


@pytest.mark.parametrize("path", _all_commands(), ids=lambda p: " ".join(p) or "robostar")
def test_every_command_has_help_with_an_example(path: list[str]) -> None:
    result = CliRunner().invoke(cli, [*path, "--help"])
    assert result.exit_code == 0
    assert "Example" in result.stdout
    assert "robostar" in result.stdout.split("Example", 1)[1]


# -- sim -----------------------------------------------------------------------------------------
def test_sim_serves_until_terminated(as_json: AsJson) -> None:
    env = dict(os.environ)
    env.pop("ROBOSTAR_PORT", None)
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "robostar.cli",
            "--json",
            "sim",
            "--listen",
            "127.0.0.1:0",
            "--options",
            "speedup=50&channels=1",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        assert process.stdout is not None
        ready = json.loads(process.stdout.readline())
        (url,) = ready["endpoints"]
        assert url.startswith("tcp://127.0.0.1:")
        info = as_json(CliRunner().invoke(cli, ["--port", url, "--json", "info"]))
        assert info["max_channels"] == 1
    finally:
        process.terminate()
        assert process.wait(15) == 0


def test_sim_human_and_bad_options(run: Run) -> None:
    assert run("sim", "--config", "x.toml", "--options", "channels=1").exit_code == 2
    bad = run("sim", "--options", "colour=blue", "--listen", "127.0.0.1:0")
    assert bad.exit_code == 2


# -- demo ----------------------------------------------------------------------------------------
def test_demo_tour(run: Run, as_json: AsJson) -> None:
    data = as_json(run("--json", "demo", "--fast"))
    titles = [s["title"] for s in data["steps"]]
    assert titles == [
        "Who is on the line",
        "Status lamps",
        "Servo on",
        "Home",
        "Move",
        "Jog",
        "Upload a job",
        "Run the job",
        "I/O",
        "Alarms",
    ]
    assert all(s["ok"] for s in data["steps"])
    assert data["steps"][-1]["refused"]
    human = run("demo", "--fast", port="tcp://127.0.0.1:1")
    assert human.exit_code == 0
    assert "is not touched" in human.stderr
    assert "That is the tour." in human.stdout
    assert "$ robostar home" in human.stdout
