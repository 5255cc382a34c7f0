"""`robostar files history NAME` and `robostar files diff` read the line server's program
versions from its folder: the versions with who and when, a line diff of two of them, and the
last one against the controller's file now."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tests.cli.conftest import AsJson, Run

from robostar.serve.lease import Who
from robostar.serve.programs import ProgramStore

ERIN = Who("erin", "web")


def kept(tmp_path: Path) -> Path:
    store = ProgramStore(tmp_path)
    store.record("cell1", 1, "DEMO.JOB", "MAIN\nDELAY 1\nEOP\n", ERIN, "upload")
    store.record("cell1", 1, "DEMO.JOB", "MAIN\nDELAY 2\nEOP\n", Who("olga", "web"), "download")
    return tmp_path


def test_history_lists_the_versions(run: Run, as_json: AsJson, tmp_path: Path) -> None:
    store = str(kept(tmp_path))
    answer: Any = as_json(run("--json", "files", "history", "DEMO.JOB", "--store", store))
    assert [(v["version"], v["who"], v["how"]) for v in answer["versions"]] == [
        (2, "olga", "download"),
        (1, "erin", "upload"),
    ]
    shown = run("files", "history", "DEMO.JOB", "--store", store, "--line", "cell1")
    assert shown.exit_code == 0 and "erin (web)" in shown.output


def test_diff_of_two_versions_and_of_the_controllers_file(
    run: Run, as_json: AsJson, tmp_path: Path
) -> None:
    store = str(kept(tmp_path))
    answer: Any = as_json(run("--json", "files", "diff", "DEMO.JOB", "--store", store))
    assert "-DELAY 1" in answer["diff"] and "+DELAY 2" in answer["diff"]
    same: Any = as_json(run("--json", "files", "diff", "DEMO.JOB", "2", "2", "--store", store))
    assert same["diff"] == []
    current: Any = as_json(
        run("--json", "files", "diff", "DEMO.JOB", "--current", "--store", store)
    )
    assert current["new"] == "on the controller now" and "-DELAY 2" in current["diff"]


def test_no_store_is_said_in_words(run: Run, tmp_path: Path) -> None:
    result = run("files", "history", "DEMO.JOB", "--store", str(tmp_path / "none"))
    assert result.exit_code != 0 and "no program versions in" in result.output.lower()
