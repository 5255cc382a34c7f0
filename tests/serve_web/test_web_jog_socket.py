"""The jog socket's inching, speed and axis checks, and "teach here" over HTTP: a step other than
0.01/0.1/1, an axis the channel lacks, an inch while the axis jogs, and a teach without the
engineer role, a confirmation or a point file are refused before anything reaches the wire."""

from __future__ import annotations

from typing import Any

import httpx
from web_harness import Stack, ask, login


def test_bad_inches_are_refused_before_the_wire(stack: Stack, jog: Any) -> None:
    before = stack.in_sim(lambda c: c.executions["BD"])
    inch = {"type": "inch", "channel": 1, "axis": 1, "direction": "+", "motion": "joint"}
    answer = ask(jog, {**inch, "step": 5})
    assert answer["type"] == "error" and "0.01" in answer["error"]
    answer = ask(jog, {**inch, "channel": 2, "axis": 3, "step": 0.1})  # channel 2 has 2 axes
    assert answer["type"] == "error" and "axes 1-2" in answer["error"]
    assert stack.in_sim(lambda c: c.executions["BD"]) == before


def test_a_jog_on_an_axis_the_channel_lacks_is_refused(stack: Stack, jog: Any) -> None:
    before = stack.in_sim(lambda c: c.executions["BE"])
    answer = ask(jog, {"type": "start", "channel": 2, "axis": 4, "direction": "+"})
    assert answer["type"] == "error" and "axes 1-2" in answer["error"]
    assert stack.in_sim(lambda c: c.executions["BE"]) == before


def test_no_inch_while_the_axis_jogs(stack: Stack, jog: Any) -> None:
    stack.in_sim(lambda c: setattr(c.model.channels[0], "servo", True))
    try:
        answer = ask(jog, {"type": "start", "channel": 1, "axis": 4, "direction": "+"})
        assert answer["type"] == "moving", answer
        before = stack.in_sim(lambda c: c.executions["BD"])
        inch = {"type": "inch", "channel": 1, "axis": 4, "direction": "+", "step": 1.0}
        answer = ask(jog, inch)
        assert answer["type"] == "error" and "release the jog" in answer["error"]
        assert stack.in_sim(lambda c: c.executions["BD"]) == before
        assert ask(jog, {"type": "stop"})["type"] == "stopped"
    finally:
        stack.in_sim(lambda c: setattr(c.model.channels[0], "servo", False))


def test_jog_speed_sets_the_channels_speed_in_percent(stack: Stack, jog: Any) -> None:
    answer = ask(jog, {"type": "speed", "channel": 2, "percent": 25})
    assert answer == {"type": "speed", "channel": 2, "percent": 25}
    assert stack.in_sim(lambda c: c.model.channels[1].speed) == 250
    assert ask(jog, {"type": "speed", "channel": 2, "percent": 150})["type"] == "error"


def test_teach_here_needs_an_engineer_a_confirmation_and_a_point_file(stack: Stack) -> None:
    teach = {"channel": 1, "file": "TCH.PNT", "number": 3, "confirmed": True}
    before = stack.in_sim(lambda c: c.executions["FB"])
    with httpx.Client(base_url=stack.url, timeout=10) as http:
        token = login(http, "olga")
        answer = http.post("/line/cell1/jog/teach", json=teach, headers={"x-csrf-token": token})
        assert answer.status_code == 403 and "engineer" in answer.json()["error"]
    with httpx.Client(base_url=stack.url, timeout=10) as http:
        token = login(http, "erin")
        headers = {"x-csrf-token": token}
        unconfirmed = {**teach, "confirmed": False}
        answer = http.post("/line/cell1/jog/teach", json=unconfirmed, headers=headers)
        assert answer.status_code == 428
        answer = http.post(
            "/line/cell1/jog/teach", json={**teach, "file": "MAIN.JOB"}, headers=headers
        )
        assert answer.status_code == 400 and "point file" in answer.json()["error"]
    assert stack.in_sim(lambda c: c.executions["FB"]) == before
