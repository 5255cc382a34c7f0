"""The controller page: an XY view with the workspace from the soft limits, positions named
X/Y/Z/R beside the joint angles, lamps whose off state is neutral, speed in percent (the wire's
per mille stays on the wire), the emergency stop on every page, and a favicon."""

from __future__ import annotations

import html
import json
import re

import httpx
import pytest
from web_harness import Stack, login, wait_until

from robostar.serve.faces.web.workspace import parse_links, parse_ranges, scara_outline


def view_of(page: str, channel: int) -> dict[str, object]:
    canvases = re.findall(r'<canvas class="xyview"[^>]*data-view="([^"]*)"', page)
    assert len(canvases) >= channel, "no XY view"
    view: dict[str, object] = json.loads(html.unescape(canvases[channel - 1]))
    return view


def test_the_xy_view_has_the_workspace_of_the_soft_limits(
    stack: Stack, client: httpx.Client
) -> None:
    page = client.get("/line/cell1").text
    scara = view_of(page, 1)["workspace"]
    assert isinstance(scara, dict)
    # the simulated SCARA: links 350 + 250 mm, J1 -120..120, J2 -145..145: reach 600 mm
    _, ymin, xmax, ymax = scara["box"]
    assert xmax == pytest.approx(600.0, abs=1.0)
    assert ymax == pytest.approx(600.0, abs=15.0) and ymin == pytest.approx(-600.0, abs=15.0)
    cartesian = view_of(page, 2)["workspace"]
    assert isinstance(cartesian, dict)
    assert cartesian["box"] == [0.0, 0.0, 600.0, 600.0]
    assert "Workspace from the soft limits" in page


def test_positions_are_named_and_shown_with_the_joint_angles(
    stack: Stack, client: httpx.Client
) -> None:
    page = client.get("/line/cell1").text
    for name in ("<th>X</th>", "<th>Y</th>", "<th>Z</th>", "<th>R</th>", "<th>J1</th>"):
        assert name in page
    assert 'data-key="cell1/ch1/angles"' in page
    assert "Axis 1" not in page


def test_speed_is_set_in_percent(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=10) as http:
        token = login(http, "olga")
        body = {"action": "speed", "channel": 2, "percent": 37.5, "confirmed": True}
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 200, answer.text
        assert stack.in_sim(lambda c: c.model.channels[1].speed) == 375
        body["percent"] = 101
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 400 and "percentage" in answer.json()["error"]
        page = http.get("/line/cell1").text
    assert "‰" not in page and 'class="speed-input"' in page


def test_every_page_has_the_stop_and_a_favicon(stack: Stack, client: httpx.Client) -> None:
    for path in ("/", "/line/cell1", "/line/cell1/jog", "/audit", "/health", "/login"):
        page = client.get(path).text
        assert 'id="stop-all"' in page and "no enabling device" in page, path
    icon = client.get("/favicon.ico")
    assert icon.status_code == 200 and icon.headers["content-type"].startswith("image/svg")


def test_the_parameter_texts_are_read_leniently() -> None:
    assert parse_ranges("RANG: 1:-120.000~120.000 2:-145~145") == [(-120.0, 120.0), (-145, 145)]
    assert parse_links("LENG: 350.000 250.000") == (350.0, 250.0)
    assert parse_links("LENG: 0.000 0.000") is None
    border, reach = scara_outline((350.0, 250.0), (-90.0, 90.0), (-10.0, 10.0))
    assert border[0] == border[-1]  # closed
    assert max(x for x, _ in reach) == pytest.approx(600.0)  # the stretched arm
    assert len(scara_outline((350.0, 250.0), (-90.0, 90.0), (10.0, 20.0))) == 1  # no J2 = 0


def test_job_select_takes_a_job_of_the_channels_own(stack: Stack, client: httpx.Client) -> None:
    assert client.get("/line/cell1/jobs/1").status_code == 403  # FD is a transfer: signed in
    with httpx.Client(base_url=stack.url, timeout=10) as http:
        token = login(http, "olga")
        listed = http.get("/line/cell1/jobs/1").json()["jobs"]
        assert {"name": "DEMO.JOB", "number": 1} in [
            {"name": j["name"], "number": j["number"]} for j in listed
        ]
        assert http.get("/line/cell1/jobs/3").status_code == 404  # two channels here
        before = stack.in_sim(lambda c: c.executions["DC"])
        body = {"action": "job_select", "channel": 1, "job": "DEMO.PNT", "confirmed": True}
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 400 and "JOB file" in answer.json()["error"]
        assert stack.in_sim(lambda c: c.executions["DC"]) == before


def test_the_files_page_offers_the_controllers_channels_only(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=10) as http:
        login(http, "vic")
        page = http.get("/line/cell1/files").text
        assert '?channel=1"' in page and '?channel=2"' in page and '?channel=3"' not in page
        assert "≤ 1 KB" in page  # FD counts in KB: a small file is not "1 KB"
        assert "has no channel 3" in http.get("/line/cell1/files?channel=3").text
        assert "bytes as downloaded" in http.get("/line/cell1/files/1/DEMO.PNT").text


def test_the_age_of_a_value_at_rest_is_the_time_since_it_was_read(
    stack: Stack, client: httpx.Client
) -> None:
    """A position that does not change sends no event; its age is since the last read all the
    same (the poller reads it every 50 ms here), not since it last changed."""
    import time

    time.sleep(1.5)  # channel 2 at rest: its position unchanged all that time
    wait_until(
        lambda: client.get("/line/cell1/ages").json()["ages"]["ch2/position"] < 1.0,
        what="an age under 1 s (it grew while the value was read again)",
    )
