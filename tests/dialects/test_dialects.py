"""The client against every dialect of the simulator: each writes its answers in another form
the manual allows, and download, backup, restore and every file, global and point
command must work against all of them, so a strict reading can never come back."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from robostar import Client
from robostar.commands.files import DownloadFile
from robostar.commands.status import ReadPosition
from robostar.commands.variables import ReadGlobalFloat
from robostar.errors import UsageError
from robostar.sim import SimConfig
from robostar.sim.dialects import DIALECTS, dialect_named
from robostar.testing import N1Sim
from robostar.types import ArmForm, CoordSystem, JobFile, Point, Position, PositionKind

JOB = ("MAIN", "MOVE P1", "MOVE P2", "EOP")


@pytest.fixture(
    params=[
        pytest.param(name, marks=pytest.mark.n1_sim(dialect=name, speedup=200, seed=7))
        for name in sorted(DIALECTS)
    ]
)
def robot(n1_client: Client, n1_sim: N1Sim, request: pytest.FixtureRequest) -> Iterator[Client]:
    # The plugin's own fixtures (robostar.testing), one simulator per dialect.
    assert n1_sim.controller.config.dialect == request.param
    yield n1_client


def test_positions(robot: Client) -> None:
    robot.home(1)
    robot.wait_homed(1, timeout=10)
    for kind in ("angle", "xy", "pulse"):
        position = robot.position(1, kind)
        assert len(position.axes) == 4
    robot.move_by(1, (5.0, 0.0, 0.0, 0.0), coords="angle")
    robot.wait_stopped(1, timeout=10)
    assert robot.position(1, "angle").axes[0] == pytest.approx(5.0, abs=0.01)


@pytest.mark.parametrize("value", [0.0, -1.25, 12345.123, 123456.123, -99999.999])
def test_global_floats_round_trip(robot: Client, value: float) -> None:
    robot.write_global_float(7, value)
    assert robot.read_global_float(7) == pytest.approx(value)


def test_global_ints_and_points(robot: Client) -> None:
    robot.write_global_int(3, -4711)
    assert robot.read_global_int(3) == -4711
    point = Point((10.5, -20.25, 30.0, 45.125))
    robot.write_global_point(1, 12, point)
    got = robot.read_global_point(1, 12)
    assert got.axes[:4] == pytest.approx(point.axes)


def test_job_upload_download_and_every_file_command(robot: Client) -> None:
    robot.upload_job(1, "DJ.JOB", JOB)
    assert robot.download_job(1, "DJ.JOB") == JobFile(JOB)
    assert robot.file_exists(1, "DJ.JOB")
    names = {record.name.upper() for record in robot.list_files(1)}
    assert "DJ.JOB" in names
    robot.copy_file(1, "DJ.JOB", "DK.JOB")
    robot.rename_file(1, "DK.JOB", "DL.JOB")
    assert robot.download_job(1, "DL.JOB").lines == JOB
    robot.delete_file(1, "DL.JOB")
    assert not robot.file_exists(1, "DL.JOB")
    robot.alarm_history()


def test_points_upload_and_download(robot: Client) -> None:
    points = {1: Point((1.0, 2.0, 3.0, 4.0)), 8: Point((-100.5, 20.25, 0.0, 90.0))}
    robot.upload_points(1, "DP.PNT", points)
    for coords in ("angle", "xy"):
        got = robot.download_points(1, "DP.PNT", coords=coords)
        assert set(got.points) == {1, 8}
    got = robot.download_points(1, "DP.PNT")
    assert got.points[8].axes == pytest.approx(points[8].axes)


def test_servo_and_job_selection_wait(robot: Client) -> None:
    robot.upload_job(1, "DW.JOB", JOB)
    robot.home(1)
    robot.wait_homed(1, timeout=10)
    assert robot.servo(1, True) >= 0
    assert robot.select_job(1, "DW.JOB") >= 0


def test_backup_and_restore(robot: Client, tmp_path: Path) -> None:
    robot.upload_job(1, "BK.JOB", JOB)
    robot.upload_points(1, "BK.PNT", {3: Point((1.0, 2.0, 3.0, 4.0))})
    manifest = robot.backup(tmp_path / "backup")
    assert any(entry.name.upper() == "BK.JOB" for entry in manifest.files)
    robot.delete_file(1, "BK.JOB")
    robot.restore(tmp_path / "backup")
    assert robot.download_job(1, "BK.JOB").lines == JOB


# -- each dialect really is different ---------------------------------------------------------
def _answers(dialect: str, command: ReadPosition) -> list[bytes]:
    position = Position(PositionKind.ANGLE, (1.5, 1.5, 1.5, 1.5), ArmForm.NONE)
    return dialect_named(dialect).dress(command, command.encode_answer(position))


def test_left_aligned_and_padded_coordinates_differ_from_the_manual() -> None:
    command = ReadPosition(1, PositionKind.ANGLE)
    manual, left, padded = (
        _answers(name, command)[0] for name in ("manual", "left-aligned", "padded")
    )
    assert manual[1:11] == b"     1.500"
    assert left[1:11] == b"1.500     "
    assert padded[1:11] == b"+00001.500"


def test_capacity_announces_2000_and_padded_spaces_the_figure() -> None:
    job = JobFile(JOB)
    command = DownloadFile(1, "RS.JOB", CoordSystem.ANGLE)
    packets = command.encode_answer(job)
    assert dialect_named("capacity").dress(command, packets)[0][2:] == b"2000"
    assert dialect_named("padded").dress(command, packets)[0][2:] == b"   4"
    assert dialect_named("manual").dress(command, packets)[0][2:] == b"0004"


def test_padded_gr_float_takes_ten_bytes() -> None:
    command = ReadGlobalFloat(1)
    packets = command.encode_answer(1.5)
    assert dialect_named("padded").dress(command, packets) == [b"0" + b"+00001.500"]


def test_an_unknown_dialect_is_refused_with_the_names() -> None:
    with pytest.raises(UsageError, match="capacity"):
        SimConfig(dialect="strict")
    with pytest.raises(UsageError, match="left-aligned"):
        Client("sim://?dialect=nope")


def test_sim_urls_take_a_dialect() -> None:
    with Client("sim://?dialect=capacity") as c:
        c.upload_job(1, "UR.JOB", JOB)
        assert c.download_job(1, "UR.JOB").announced == 2000
