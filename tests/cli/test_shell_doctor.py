"""`doctor` typed in the shell on a serial line says to run it outside the shell (its baud
probe needs the port, which the shell holds) instead of blaming "another program"."""

from __future__ import annotations

from collections.abc import Callable

from robostar.sim import SimConfig, VirtualController

from .conftest import Run


def test_doctor_on_a_serial_line_says_to_leave_the_shell(
    run: Run, served: Callable[..., str]
) -> None:
    device = served(VirtualController(SimConfig(speedup=50)), pty=True)
    result = run("shell", input="doctor --count 2\nstatus\n", port=device)
    said = " ".join(result.stderr.split())
    assert "leave the shell (exit) and run `robostar doctor` there" in said, said
    assert "busy" not in said and "another program" not in said
    assert "Status" in result.stdout  # the shell's own connection still works
    assert result.exit_code == 2


def test_doctor_on_a_tcp_line_runs_in_the_shell(run: Run, served: Callable[..., str]) -> None:
    url = served(VirtualController(SimConfig(speedup=50)))
    result = run("shell", input="doctor --count 2\n", port=url)
    assert result.exit_code == 0, result.output
    assert "All good." in result.stdout
