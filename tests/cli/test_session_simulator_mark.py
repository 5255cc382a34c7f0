"""A simulator never passes for the robot, whatever its configuration calls it.

Over tcp:// and a pseudo-terminal the console knows a simulator only by its AD identity; the
simulator always ends its version in -SIM (robostar.commands.identity), so one configured with
a robot's name and version is still shown, and backed up, as a simulator. A controller whose
version lacks the mark is a controller, whatever its name.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

import pytest
from click.testing import Result

from .conftest import RealControllerStandIn

Run = Callable[..., Result]
Serve = Callable[..., str]

needs_pty = pytest.mark.skipif(os.name != "posix", reason="pseudo-terminals need POSIX")

ROBOT_NAME = "N1"
ROBOT_VERSION = "N1RO 03.02.05"


def _robot_like_simulator() -> object:
    from robostar.sim import SimConfig, VirtualController

    return VirtualController(SimConfig(speedup=50, name=ROBOT_NAME, version=ROBOT_VERSION))


@pytest.fixture(params=["tcp", pytest.param("pty", marks=needs_pty)])
def disguised(request: pytest.FixtureRequest, served: Serve) -> str:
    """A simulator configured with a robot's name and version, served over tcp:// or a pty."""
    return served(_robot_like_simulator(), pty=request.param == "pty")


def test_a_simulator_configured_as_a_robot_shows_the_simulator_banner(
    run: Run, disguised: str
) -> None:
    result = run("status", port=disguised)
    assert result.exit_code == 0, result.output
    assert f"SIMULATOR | {disguised}" in result.stderr
    assert "controller |" not in result.stderr


def test_a_simulator_configured_as_a_robot_says_simulator_in_json(run: Run, disguised: str) -> None:
    result = run("--json", "info", port=disguised)
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["simulator"] is True and data["url"] == disguised
    # Its name is as configured; its version carries the mark after the configured text.
    assert data["name"] == ROBOT_NAME and data["version"] == f"{ROBOT_VERSION}-SIM"
    failed = run("--json", "files", "rm", "NOPE.JOB", port=disguised)
    assert failed.exit_code == 3
    assert json.loads(failed.stderr)["simulator"] is True


def test_a_backup_of_a_simulator_configured_as_a_robot_says_simulator(
    run: Run, disguised: str, tmp_path: Path
) -> None:
    folder = tmp_path / "backup"
    result = run("backup", str(folder), port=disguised)
    assert result.exit_code == 0, result.output
    data = json.loads((folder / "manifest.json").read_text())
    assert data["target"] == disguised and data["simulator"] is True
    assert data["controller"]["name"] == ROBOT_NAME


@pytest.fixture(params=["tcp", pytest.param("pty", marks=needs_pty)])
def real(request: pytest.FixtureRequest, served: Serve) -> str:
    """A controller answering AD as a real N1 does (no mark), over tcp:// or a pty."""
    return served(RealControllerStandIn(), pty=request.param == "pty")


def test_a_controller_without_the_mark_is_shown_as_a_controller(run: Run, real: str) -> None:
    result = run("status", port=real)
    assert result.exit_code == 0, result.output
    assert f"controller | {real}" in result.stderr and "SIMULATOR" not in result.stderr
    data = json.loads(run("--json", "info", port=real).stdout)
    assert data["simulator"] is False and data["version"] == ROBOT_VERSION


def test_a_backup_of_a_controller_without_the_mark_says_robot(
    run: Run, real: str, tmp_path: Path
) -> None:
    folder = tmp_path / "backup"
    assert run("backup", str(folder), port=real).exit_code == 0
    data = json.loads((folder / "manifest.json").read_text())
    assert data["target"] == real and data["simulator"] is False


def test_a_controller_named_like_a_simulator_is_still_a_controller(
    run: Run, served: Serve, tmp_path: Path
) -> None:
    # NAME is set on the controller by whoever runs it; only the firmware's version marks a
    # simulator, so a real N1 named PRESS-SIM is not taken for one.
    port = served(RealControllerStandIn(name="PRESS-SIM"))
    data = json.loads(run("--json", "info", port=port).stdout)
    assert data["name"] == "PRESS-SIM" and data["simulator"] is False
    assert "controller |" in run("status", port=port).stderr
    assert run("backup", str(tmp_path / "b"), port=port).exit_code == 0
    assert json.loads((tmp_path / "b" / "manifest.json").read_text())["simulator"] is False


def test_sim_alarm_clear_refuses_a_controller_named_like_a_simulator(
    run: Run, served: Serve
) -> None:
    port = served(RealControllerStandIn(name="PRESS-SIM"))
    result = run("sim", "alarm", "clear", port=port)
    assert result.exit_code == 2
    assert "is a real controller (PRESS-SIM)" in result.output


def test_sim_alarm_clear_works_on_a_simulator_configured_as_a_robot(
    run: Run, served: Serve
) -> None:
    port = served(_robot_like_simulator())
    assert run("estop", port=port).exit_code == 0
    result = run("sim", "alarm", "clear", port=port)
    assert result.exit_code == 0, result.output
    assert "SIMULATOR: alarms cleared." in result.stdout


@needs_pty
def test_a_simulator_behind_a_serial_name_of_its_own_is_asked_too(
    run: Run, served: Serve, tmp_path: Path
) -> None:
    """Not only loopback TCP and /dev/pts: a simulator can sit behind any port name (a
    null-modem cable's /dev/ttyUSB0, a udev link, another machine's TCP); every target but
    sim:// is asked, so a port name proves nothing."""
    pty = served(_robot_like_simulator(), pty=True)
    link = tmp_path / "ttyN1"
    link.symlink_to(pty)
    result = run("status", port=str(link))
    assert result.exit_code == 0, result.output
    assert f"SIMULATOR | {link}" in result.stderr
    assert "controller |" not in result.stderr
