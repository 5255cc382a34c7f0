"""The target of a run: never implicit; SIMULATOR said aloud; profiles; JSON usage errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from robostar.cli import cli

SIM = "sim://?speedup=50"


@pytest.fixture(autouse=True)
def _no_ambient_target(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("ROBOSTAR_PORT", raising=False)
    monkeypatch.delenv("ROBOSTAR_ROBOT", raising=False)
    monkeypatch.setenv("ROBOSTAR_CONFIG", str(tmp_path / "robots.toml"))


def _invoke(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(cli, list(args))
    return result.exit_code, result.stdout, result.stderr


@pytest.mark.parametrize("argv", [["status"], ["servo", "on"], ["files", "ls"], ["doctor"]])
def test_no_target_refuses_and_says_how(argv: list[str], tmp_path: Path) -> None:
    trace = tmp_path / "t.jsonl"
    code, _, err = _invoke("--trace", str(trace), *argv)
    assert code == 2
    assert "--port" in err and "--robot" in err and "sim://" in err
    assert not trace.exists() or trace.read_text() == ""


def test_no_target_json_is_an_error_object() -> None:
    code, out, err = _invoke("--json", "status")
    assert code == 2 and out == ""
    error = json.loads(err)["error"]
    assert error["exit_code"] == 2 and "--port" in error["message"]


def test_root_usage_error_in_json() -> None:
    code, _, err = _invoke("--json", "--channel", "9", "status")
    assert code == 2
    assert "channel" in json.loads(err)["error"]["message"]


def test_subcommand_usage_error_in_json() -> None:
    code, _, err = _invoke("--port", SIM, "--json", "io", "in", "9")
    assert code == 2
    assert "port" in json.loads(err)["error"]["message"].lower()


def test_offline_commands_need_no_target() -> None:
    code, out, _ = _invoke("decode", "--hex", "02 41 41 03")
    assert code == 0, out
    code, out, _ = _invoke("--dry-run", "servo", "on")
    assert code == 0 and "Nothing was sent" in out


def test_simulator_is_named_in_human_and_json_output() -> None:
    code, out, err = _invoke("--port", SIM, "status")
    assert code == 0 and "SIMULATOR" in err
    code, out, _ = _invoke("--port", SIM, "--json", "info")
    assert code == 0 and json.loads(out)["simulator"] is True
    code, out, _ = _invoke("--port", SIM, "--dry-run", "servo", "on")
    assert code == 0 and "(SIMULATOR)" in out


def test_environment_variable_is_a_target(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROBOSTAR_PORT", SIM)
    code, out, _ = _invoke("--json", "status")
    assert code == 0 and json.loads(out)["simulator"] is True


def _write(tmp_path: Path, text: str) -> None:
    (tmp_path / "robots.toml").write_text(text, encoding="utf-8")


def test_profile_gives_the_target_and_shows_in_the_banner(tmp_path: Path) -> None:
    _write(
        tmp_path,
        f'[robots.bench]\nport = "{SIM}"\ntimeout = 1.5\nrobot_type = "SCARA"\n'
        'channels = { 1 = "left arm" }\n\n[robots.cell1]\nport = "/dev/ttyUSB9"\nbaud = 9600\n',
    )
    code, out, err = _invoke("--robot", "bench", "status")
    assert code == 0 and "SIMULATOR" in err and "robot bench" in err
    code, out, _ = _invoke("--robot", "bench", "--json", "status")
    data = json.loads(out)
    assert data["simulator"] is True and data["robot"] == "bench"
    code, out, _ = _invoke("--robot", "bench", "--json", "profiles")
    listed = json.loads(out)
    assert code == 0 and [p["name"] for p in listed["profiles"]] == ["bench", "cell1"]
    assert listed["profiles"][0]["active"] and listed["profiles"][0]["channels"] == {
        "1": "left arm"
    }
    assert listed["profiles"][1]["baud"] == 9600 and not listed["profiles"][1]["simulator"]
    code, out, _ = _invoke("profiles")
    assert code == 0 and "cell1" in out and "/dev/ttyUSB9" in out


def test_unknown_profile_lists_the_known_ones(tmp_path: Path) -> None:
    _write(tmp_path, f'[robots.bench]\nport = "{SIM}"\n')
    code, _, err = _invoke("--robot", "nosuch", "status")
    assert code == 2 and "nosuch" in err and "bench" in err


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("[robots.a]\nbaud = 9600\n", "robots.a.port"),
        ('[robots.a]\nport = "sim://"\ntimeout = "soon"\n', "robots.a.timeout"),
        ('[robots.a]\nport = "sim://"\ntimeout = inf\n', "robots.a.timeout"),
        ('[robots.a]\nport = "sim://"\nbaud = -1\n', "robots.a.baud"),
        ('[robots.a]\nport = "sim://"\ncolour = "red"\n', "robots.a.colour"),
        ('[robots.a]\nport = "sim://"\nchannels = { 4 = "x" }\n', "robots.a.channels.4"),
        ("[robots.a\n", "not valid TOML"),
    ],
)
def test_profile_errors_name_the_key(tmp_path: Path, text: str, key: str) -> None:
    _write(tmp_path, text)
    code, _, err = _invoke("--robot", "a", "status")
    assert code == 2 and key in err.replace("\n", "")


def test_a_served_simulator_is_named_too(sim_line: object, tmp_path: Path) -> None:
    url = sim_line.url  # type: ignore[attr-defined]
    trace = tmp_path / "t.jsonl"
    code, out, err = _invoke("--port", url, "--trace", str(trace), "estop")
    assert code == 0 and err.startswith("SIMULATOR | tcp://127.0.0.1:")
    code, out, _ = _invoke("--port", url, "--json", "reset")
    assert json.loads(out)["simulator"] is True
    code, _, err = _invoke("--port", url, "files", "rm", "A B.JOB")
    assert code == 2 and "Nothing was sent" in err  # the AD that identified it is not counted
