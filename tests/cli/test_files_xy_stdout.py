"""`files get NAME.PNT - --xy`: the points in XY keep their `#COORDS XY` mark on stdout too, so
a redirected copy is refused by `files put` instead of writing millimetres as degrees."""

from __future__ import annotations

from pathlib import Path

from .conftest import AsJson, Run, SimLine


def test_xy_points_on_stdout_carry_the_mark_and_put_refuses_them(
    on: Run, sim_line: SimLine, tmp_path: Path
) -> None:
    before = on("files", "get", "DEMO.PNT", "-")
    assert before.exit_code == 0, before.output
    got = on("files", "get", "DEMO.PNT", "-", "--xy")
    assert got.exit_code == 0, got.output
    assert got.stdout.splitlines()[0] == "#COORDS XY"
    saved = tmp_path / "demo_xy.pnt"
    saved.write_text(got.stdout)  # what `> demo_xy.pnt` keeps
    put = on("files", "put", str(saved), "--name", "DEMO.PNT")
    assert put.exit_code == 2
    assert "XY" in put.stderr and "degrees" in put.stderr
    assert on("files", "get", "DEMO.PNT", "-").stdout == before.stdout  # untouched


def test_angle_points_on_stdout_have_no_mark(run: Run) -> None:
    got = run("files", "get", "DEMO.PNT", "-")
    assert got.exit_code == 0, got.output
    assert got.stdout.splitlines()[0].startswith("P0001")


def test_json_says_which_coordinates(run: Run, as_json: AsJson, tmp_path: Path) -> None:
    xy = as_json(run("--json", "files", "get", "DEMO.PNT", "-", "--xy"))
    assert xy["coords"] == "xy" and xy["lines"][0].startswith("P0001")
    assert as_json(run("--json", "files", "get", "DEMO.PNT", "-"))["coords"] == "angle"
    assert as_json(run("--json", "files", "get", "DEMO.JOB", "-"))["coords"] is None
    saved = as_json(run("--json", "files", "get", "DEMO.PNT", str(tmp_path / "d.pnt"), "--xy"))
    assert saved["coords"] == "xy"
