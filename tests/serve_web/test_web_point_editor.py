"""The point editor: its fields hold the point's current values (angles, as the controller has
them), and a refusal comes back on the page in words with what was entered (a browser), or
as JSON to any other client."""

from __future__ import annotations

from typing import Any

import httpx
from web_harness import PASSWORDS, Stack, login

from robostar.commands.files import DownloadFile
from robostar.protocol.fields import FileName
from robostar.types import CoordSystem

HTML = {"accept": "text/html,application/xhtml+xml"}


def demo_points(stack: Stack) -> Any:
    name = FileName.parse("DEMO.PNT")
    return stack.call(stack.line.read(DownloadFile(1, name, CoordSystem.ANGLE), max_age=0))


def test_the_fields_hold_the_points_values(stack: Stack) -> None:
    points = demo_points(stack).points
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        login(http, "erin")
        page = http.get("/line/cell1/files/1/DEMO.PNT?edit=2").text
    assert 'name="number" min="0" max="9999" required value="2"' in page
    for i, value in enumerate(points[2].axes, start=1):
        assert f'name="axis{i}" class="axis-input" value="{value:.3f}"' in page
    assert "J1 (°)" in page  # the channel's joint names, not "Axis 1"


def test_a_refusal_is_shown_on_the_page_in_words(stack: Stack) -> None:
    before = demo_points(stack)
    count = len(before.points[1].axes)
    entered = {f"axis{i}": "1.5" for i in range(1, count + 1)} | {"axis2": ""}
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        token = login(http, "erin")
        data = {"csrf_token": token, "number": "1", "confirmed": "yes", **entered}
        path = "/line/cell1/files/1/DEMO.PNT/point"
        answer = http.post(path, data=data, headers=HTML)
        assert answer.status_code == 400
        assert "The point was not written: axis 2: enter a number." in answer.text
        assert 'name="axis1" class="axis-input" value="1.5"' in answer.text  # kept
        assert "{&#34;ok&#34;" not in answer.text and '{"ok"' not in answer.text
        as_json = http.post(path, data=data)  # a script gets JSON, as before
        assert as_json.status_code == 400 and "axis 2" in as_json.json()["error"]
    assert demo_points(stack) == before


def test_choosing_a_point_fills_the_fields_in_the_browser(page: Any, stack: Stack) -> None:
    from playwright.sync_api import expect

    points = demo_points(stack).points
    page.goto("/login")
    page.fill("input[name=username]", "erin")
    page.fill("input[name=password]", PASSWORDS["erin"])
    page.click("form.login button[type=submit]")
    page.wait_for_url("**/")
    page.goto("/line/cell1/files/1/DEMO.PNT")
    page.fill("#point-number", "3")
    expect(page.locator("input[name=axis1]")).to_have_value(f"{points[3].axes[0]:.3f}")
    page.fill("input[name=axis1]", "not a number")
    page.check("input[name=confirmed]")
    page.click("#point-form button[type=submit]")
    expect(page.locator("#point-error")).to_contain_text("is not a number")
