"""Teaching points: `robostar teach` and the jog pad's t/g keys, against a served simulator."""

from __future__ import annotations

import json
from typing import Any

import pytest

from robostar.cli.jogpad import AskGoto, AskTeach, Cancel, Goto, JogPad, Teach
from robostar.client import Client

from .conftest import AsJson, Run


def _home_and_move(url: str) -> tuple[float, ...]:
    with Client(url) as client:
        client.servo(1, True)
        client.home(1, wait=True)
        client.move(1, (10.0, 20.0, 5.0, 0.0), coords="angle", motion="joint", wait=True)
        return tuple(client.position(1, "angle").axes)


def test_store_shows_old_and_new_and_asks(on: Run, sim_line: Any) -> None:
    here = _home_and_move(sim_line.url)
    refused = on("teach", "store", "DEMO.PNT", "7", input="n\n")
    assert refused.exit_code == 1
    assert "old" in refused.stdout and "(empty)" in refused.stdout
    assert "10.000, 20.000, 5.000" in refused.stdout and "Nothing was written" in refused.stdout
    with Client(sim_line.url) as client:
        assert 7 not in client.download_points(1, "DEMO.PNT").points
    stored = on("teach", "store", "DEMO.PNT", "7", input="y\n")
    assert stored.exit_code == 0, stored.output
    with Client(sim_line.url) as client:
        point = client.download_points(1, "DEMO.PNT").points[7]
        assert point.axes == here and point.used
        assert 1 in client.download_points(1, "DEMO.PNT").points  # the others are kept


def test_store_global_and_goto(on: Run, as_json: AsJson, sim_line: Any) -> None:
    here = _home_and_move(sim_line.url)
    data = as_json(on("--json", "teach", "store", "--global", "100", "--yes"))
    assert data["written"] and data["old"] is None
    assert tuple(data["new"]["axes"]) == here
    with Client(sim_line.url) as client:
        assert client.read_global_point(1, 100).axes[:4] == here
        client.move(1, (0.0, 0.0, 0.0, 0.0), coords="angle", motion="joint", wait=True)
        client.set_speed(1, 700)
    moved = as_json(on("--json", "teach", "goto", "--global", "100", "--yes"))
    assert moved["moved"] is True
    with Client(sim_line.url) as client:
        assert tuple(client.position(1, "angle").axes) == pytest.approx(here, abs=1e-3)
        assert client.speed(1) == 700  # put back after the slow move


def test_goto_asks_first(on: Run, sim_line: Any) -> None:
    _home_and_move(sim_line.url)
    no = on("teach", "goto", "DEMO.PNT", "1", input="n\n")
    assert no.exit_code == 1 and "Not moved" in no.stdout
    with Client(sim_line.url) as client:
        assert tuple(client.position(1, "angle").axes)[:2] == (10.0, 20.0)


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["teach", "store", "DEMO.JOB", "1", "--yes"], "pnt"),
        (["teach", "store", "A B.PNT", "1", "--yes"], "name"),
        (["teach", "store", "DEMO.PNT", "5000", "--yes"], "number"),
        (["teach", "store", "--global", "2000", "--yes"], "number"),
        (["teach", "store", "DEMO.PNT", "--global", "1", "--yes"], "global"),
        (["teach", "goto", "--global", "x", "--yes"], "number"),
    ],
)
def test_teach_bad_input(on: Run, args: list[str], words: str) -> None:
    result = on(*args)
    assert result.exit_code == 2
    assert words in result.output.lower()


def test_pad_teach_keys() -> None:
    pad = JogPad(axes=4, speed=300)
    assert pad.key("t", 0.0) == []  # teach keys are off without --teach
    pad.teaching = True
    assert pad.key("t", 0.0) == [] and "store" in pad.prompt()
    pad.key("1", 0.0)
    pad.key("2", 0.0)
    assert pad.axis == 1  # digits go to the point number, not the axis
    assert pad.key("enter", 0.0) == [AskTeach(12)]
    assert pad.key("y", 0.0) == [Teach(12)]
    pad.key("g", 0.0)
    pad.key("3", 0.0)
    assert pad.key("enter", 0.0) == [AskGoto(3)]
    assert pad.key("n", 0.0) == [Cancel()]
    pad.key("g", 0.0)
    pad.key("3", 0.0)
    pad.key("enter", 0.0)
    assert pad.key("y", 0.0) == [Goto(3)]
    pad.key("g", 0.0)
    assert pad.key("esc", 0.0) == [Cancel()] and pad.prompt() == ""


def test_pad_teaches_in_a_terminal(terminal: Any, sim_line: Any) -> None:
    _home_and_move(sim_line.url)
    term = terminal("--port", sim_line.url, "jog", "--teach", "DEMO.PNT")
    term.wait_for("robostar jog")
    term.send("t")
    term.send("9")
    term.wait_for("point: 9_")
    term.send("\r")
    term.wait_for("Store it? y/n")
    term.send("y")
    term.wait_for("stored")
    term.send("q")
    assert term.wait_exit() == 0
    with Client(sim_line.url) as client:
        assert client.download_points(1, "DEMO.PNT").points[9].axes[:2] == (10.0, 20.0)


def test_json_teach_needs_yes(on: Run) -> None:
    result = on("--json", "teach", "store", "--global", "1")
    assert result.exit_code == 2
    assert "--yes" in json.loads(result.stderr.splitlines()[-1])["error"]["message"]


def test_arm_is_honoured_with_xy(on: Run, as_json: AsJson) -> None:
    for arm in ("left", "right"):
        args = ["global", "set", "point", "20", "300", "200", "0", "0", "--xy", "--arm", arm]
        assert on(*args).exit_code == 0
        read = as_json(on("--json", "global", "get", "point", "20"))
        assert read["point"]["arm"] == arm
