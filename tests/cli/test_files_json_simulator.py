"""A --json error raised before the target was asked what it is says "simulator": null, not
false (a served simulator was called a controller); sim:// stays true, an asked target says."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from click.testing import Result

from .conftest import RealControllerStandIn, Run, SimLine


def _error(result: Result) -> dict[str, Any]:
    data = json.loads(result.stderr)
    assert isinstance(data, dict)
    return data


def test_before_asking_a_served_target_is_not_known(
    run: Run, sim_line: SimLine, served: Callable[..., str]
) -> None:
    real = served(RealControllerStandIn())
    for port in (sim_line.url, real):
        early = run("--json", "files", "get", "A B.JOB", port=port)
        assert early.exit_code == 2
        assert _error(early)["simulator"] is None and _error(early)["url"] == port
    assert json.loads(run("--json", "status", port=sim_line.url).stdout)["simulator"] is True
    assert json.loads(run("--json", "status", port=real).stdout)["simulator"] is False
    asked = run("--json", "files", "rm", "NOPE.JOB", port=real)
    assert asked.exit_code == 3 and _error(asked)["simulator"] is False


def test_sim_url_is_known_without_asking(run: Run) -> None:
    early = run("--json", "files", "get", "A B.JOB", port="sim://")
    assert early.exit_code == 2 and _error(early)["simulator"] is True


def test_a_target_that_never_answered_is_not_known(run: Run) -> None:
    dead = run("--json", "status", port="tcp://127.0.0.1:1")
    assert dead.exit_code == 4 and _error(dead)["simulator"] is None


def test_a_shell_line_says_what_the_shell_found(
    run: Run, sim_line: SimLine, served: Callable[..., str]
) -> None:
    real = served(RealControllerStandIn())
    for port, found in ((sim_line.url, True), (real, False)):
        result = run("shell", input="--json files get 'A B.JOB'\n", port=port)
        assert result.exit_code == 2
        line = next(t for t in result.stderr.splitlines() if t.startswith("{"))
        assert json.loads(line)["simulator"] is found
