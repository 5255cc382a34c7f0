"""`files put` refuses what would wipe or garble a file: an empty JOB, one that is not MAIN to
EOP, a point given twice; a blank line at the end of a JOB is not uploaded as a step."""

from __future__ import annotations

from pathlib import Path

import pytest

from .conftest import Run, SimLine


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("", "is empty"),
        ("\n\n", "is empty"),
        ("JMOV P1\nEOP\n", "start with 'JMOV P1'"),
        ("MAIN\nJMOV P1\n", "end with 'JMOV P1'"),
    ],
)
def test_a_job_that_is_not_whole_is_refused(
    on: Run, sim_line: SimLine, tmp_path: Path, text: str, said: str
) -> None:
    before = sim_line.jobs()["DEMO.JOB"]
    job = tmp_path / "demo.job"
    job.write_text(text)
    result = on("files", "put", str(job), "--name", "DEMO.JOB")
    assert result.exit_code == 2, result.output
    assert said in result.stderr and "MAIN" in result.stderr
    assert sim_line.jobs()["DEMO.JOB"] == before


def test_trailing_blank_lines_are_not_steps(on: Run, sim_line: SimLine, tmp_path: Path) -> None:
    job = tmp_path / "blank.job"
    job.write_text("MAIN\r\nEOP\r\n\r\n  \n")
    result = on("files", "put", str(job), "--name", "BLANK.JOB")
    assert result.exit_code == 0, result.output
    assert "(2 lines)" in result.stdout
    assert sim_line.jobs()["BLANK.JOB"] == ["MAIN", "EOP"]


def test_a_point_given_twice_is_refused_naming_the_line(
    on: Run, sim_line: SimLine, tmp_path: Path
) -> None:
    points = tmp_path / "dup.pnt"
    points.write_text(
        "P0001     10.000     20.000     30.000      0.00011\n"
        "\n"
        "P0002     11.000     21.000     31.000      0.00011\n"
        "P0001    -99.000     88.000     77.000      0.00011\n"
    )
    result = on("files", "put", str(points), "--name", "DUP.PNT")
    assert result.exit_code == 2, result.output
    said = " ".join(result.stderr.split())
    assert "line 4: point P0001 is given again (first on line 1)" in said
    assert "DUP.PNT" not in sim_line.jobs()
