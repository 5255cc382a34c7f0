"""Every result and error says which kind of target it came from: simulator or controller."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import pytest
from click.testing import Result

from .conftest import SIM, RealControllerStandIn

Run = Callable[..., Result]


@pytest.fixture
def robot_like(served: Callable[..., str]) -> str:
    """A controller on this machine answering AD as a real N1 does (no -SIM): a served
    simulator cannot any more (tests/cli/test_session_simulator_mark.py), so a stand-in does."""
    return served(RealControllerStandIn())


def test_json_errors_say_simulator_and_url(run: Run) -> None:
    result = run("--json", "files", "rm", "NOPE.JOB")
    assert result.exit_code == 3
    data = json.loads(result.stderr)
    assert data["error"]["type"] == "FunctionFailedError" or data["error"]["exit_code"] == 3
    assert data["simulator"] is True and data["url"] == SIM


def test_json_results_and_errors_say_controller(run: Run, robot_like: str) -> None:
    ok = run("--json", "status", port=robot_like)
    assert ok.exit_code == 0, ok.output
    assert json.loads(ok.stdout)["simulator"] is False
    assert json.loads(ok.stdout)["url"] == robot_like
    failed = run("--json", "files", "rm", "NOPE.JOB", port=robot_like)
    assert failed.exit_code == 3
    data = json.loads(failed.stderr)
    assert data["simulator"] is False and data["url"] == robot_like


def test_json_usage_errors_say_the_target_too(run: Run) -> None:
    result = run("--json", "restore", ".")  # a --json restore cannot ask: --yes is needed
    assert result.exit_code == 2
    data = json.loads(result.stderr)
    assert data["simulator"] is True and data["url"] == SIM


def test_human_output_names_a_controller(run: Run, robot_like: str) -> None:
    result = run("status", port=robot_like)
    assert result.exit_code == 0, result.output
    assert f"controller | {robot_like}" in result.stderr
    assert "SIMULATOR" not in result.stderr


def test_the_simulator_banner_is_unchanged(run: Run, sim_line: Any) -> None:
    assert "SIMULATOR | sim://" in run("status").stderr
    assert f"SIMULATOR | {sim_line.url}" in run("status", port=sim_line.url).stderr


def test_a_renamed_simulator_on_sim_url_is_still_a_simulator(run: Run) -> None:
    port = "sim://?name=LINE3&version=N1RO%2003.02.05"
    result = run("--json", "info", port=port)
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["simulator"] is True
    assert "SIMULATOR" in run("info", port=port).stderr
