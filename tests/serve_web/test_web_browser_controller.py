"""The controller page in Chromium: the XY view draws the workspace, the taught points of a PNT
file and the tool's trail; a lamp that is off has no colour; the stop at the top of the page
stops the robot for an operator and tells a viewer to use the pendant."""

from __future__ import annotations

from typing import Any

from web_harness import Stack, expect, sign_in


def test_the_xy_view_shows_taught_points_and_the_trail(page: Any, stack: Stack) -> None:
    sign_in(page, "vic")
    page.goto("/line/cell1")
    page.fill("input[name=points]", "DEMO.PNT")
    page.click("form.inline-form button[type=submit]")
    legend = page.locator(".channel-card[data-channel='1'] .xy-legend")
    expect(legend).to_contain_text("points of DEMO.PNT as markers")
    expect(legend).to_contain_text("Workspace from the soft limits")
    canvas = page.locator(".channel-card[data-channel='1'] canvas.xyview")
    # the position stream draws the current point and the trail
    expect(canvas).not_to_have_attribute("data-drawn", "0")
    painted = page.evaluate(
        """(el) => { const d = el.getContext('2d').getImageData(0, 0, el.width, el.height).data;
                     let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i]) n++; return n; }""",
        canvas.element_handle(),
    )
    assert painted > 1000  # axes, grid, workspace, markers: not an empty box


def test_a_lamp_that_is_off_has_no_colour(page: Any, stack: Stack) -> None:
    page.goto("/line/cell1")
    alarm = page.locator('[data-key="cell1/ch1/status"] .lamp.alarm')
    expect(alarm).to_have_class("lamp alarm off")
    background = alarm.evaluate("(el) => getComputedStyle(el).backgroundColor")
    assert background in ("rgba(0, 0, 0, 0)", "transparent")


def test_the_stop_at_the_top(page: Any, stack: Stack) -> None:
    page.goto("/audit")
    page.click("#stop-all")
    expect(page.locator("#toast")).to_contain_text("pendant")
    sign_in(page, "olga")
    page.goto("/health")
    before = stack.in_sim(lambda c: c.executions["CF"])
    page.click("#stop-all")  # one click: a stop does not wait for a dialog
    expect(page.locator("#toast")).to_contain_text("Emergency stop sent")
    assert stack.in_sim(lambda c: c.executions["CF"]) == before + 1
    stack.in_sim(lambda c: c.model.alarms.clear())  # the host emergency alarm, for the others
