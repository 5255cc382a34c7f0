"""Piped `robostar shell` exits with the worst (highest) exit code of its lines, and a line it
cannot read counts as a usage error."""

from __future__ import annotations

from .conftest import Run


def test_an_unreadable_line_is_a_usage_error(run: Run) -> None:
    result = run("shell", input='files put "tour.job --name TOUR.JOB\nstatus\n')
    assert "cannot read the line" in result.stderr
    assert result.exit_code == 2


def test_the_worst_code_wins_whatever_the_order(run: Run) -> None:
    bad_index, refused = "global get int 9999\n", "job select NOPE.JOB\n"
    assert run("shell", input=bad_index).exit_code == 2
    assert run("shell", input=refused).exit_code == 3
    assert run("shell", input=bad_index + refused).exit_code == 3
    assert run("shell", input=refused + bad_index).exit_code == 3
    assert run("shell", input='status "\n' + refused).exit_code == 3
