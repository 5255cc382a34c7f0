"""The jog page in a real browser (Chromium) against the simulator: the pad offers the channel's
own axes by name and unit, the position panel follows the arm while it jogs, inching moves by
exactly one step, and "teach here" stores the position reached as a point of a PNT file."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest
from web_harness import Stack, confirm, expect, sign_in, wait_until

from robostar.client.sync import Client
from robostar.commands.files import DownloadFile
from robostar.types import CoordSystem, PointFile


@pytest.fixture
def servo_on(stack: Stack) -> Iterator[None]:
    """Channel 1 with its servo on and its origin found (BD needs both)."""
    origin = stack.in_sim(lambda c: c.model.channels[0].origin)
    stack.in_sim(lambda c: setattr(c.model.channels[0], "origin", True))
    stack.in_sim(lambda c: setattr(c.model.channels[0], "servo", True))
    wait_until(lambda: not stack.in_sim(lambda c: c.model.channels[0].moving))
    yield
    stack.in_sim(lambda c: setattr(c.model.channels[0], "servo", False))
    stack.in_sim(lambda c: setattr(c.model.channels[0], "origin", origin))


def joints(stack: Stack, channel: int = 1) -> tuple[float, ...]:
    return tuple(stack.in_sim(lambda c: c.model.channels[channel - 1].joints))


def visible_axes(page: Any) -> list[str]:
    return [text.strip() for text in page.locator(".jog-axis:visible .axis-name").all_inner_texts()]


def test_the_pad_offers_the_channels_own_axes(page: Any, stack: Stack) -> None:
    sign_in(page, "olga")
    page.goto("/line/cell1/jog")
    # channel 1: a 4-axis SCARA; channel 2: a 2-axis cartesian robot
    expect(page.locator(".jog-axis:visible")).to_have_count(4)
    assert visible_axes(page) == ["J1 (°)", "J2 (°)", "Z (mm)", "R (°)"]
    page.select_option("#jog-motion", "linear")
    assert visible_axes(page) == ["X (mm)", "Y (mm)", "Z (mm)", "R (°)"]
    page.select_option("#jog-channel", "2")
    expect(page.locator(".jog-axis:visible")).to_have_count(2)
    assert visible_axes(page) == ["X (mm)", "Y (mm)"]


def test_the_position_panel_follows_a_jog(page: Any, stack: Stack, servo_on: None) -> None:
    sign_in(page, "olga")
    page.goto("/line/cell1/jog")
    cell = page.locator(
        'table.position[data-channel="1"] [data-key="cell1/ch1/angles"][data-axis="1"]'
    )
    expect(cell).not_to_have_text("—")
    before = float(cell.inner_text())
    button = page.locator('.jog-btn[data-axis="1"][data-direction="+"]')
    button.dispatch_event("pointerdown")
    expect(page.locator("#jog-state")).to_contain_text("Moving")
    wait_until(lambda: float(cell.inner_text()) > before + 1.0)  # updated while moving
    # the position's age is shown once the poller's XY read has come (it may come after AC's)
    age = page.locator('[data-age-of="cell1/ch1/position"]')
    wait_until(lambda: "s ago" in age.inner_text())
    button.dispatch_event("pointerup")
    expect(page.locator("#jog-state")).to_contain_text("Stopped (released)")
    wait_until(lambda: not stack.in_sim(lambda c: c.model.channels[0].moving))
    stopped_at = joints(stack)[0]
    # the panel settles on where the arm stopped
    expect(cell).to_have_text(f"{stopped_at:.3f}")
    # the audit: the jog in one summary with how far, and no keepalive entries
    wait_until(lambda: "jog channel 1 axis 1 +" in stack.audit_path.read_text())
    entries = [json.loads(text) for text in stack.audit_path.read_text().splitlines()]
    (summary,) = [e for e in entries if e["what"].startswith("jog channel 1 axis 1 +")]
    assert f"to {stopped_at:.3f}" in summary["what"] and summary["outcome"] == "stopped: released"
    assert not any(e["what"].startswith(("JogContinue", "jog keepalive")) for e in entries)


def test_inching_moves_by_exactly_one_step(page: Any, stack: Stack, servo_on: None) -> None:
    sign_in(page, "olga")
    page.goto("/line/cell1/jog")
    page.check('input[name="jog-step"][value="1.0"]')
    start = joints(stack)
    moves_before = stack.in_sim(lambda c: c.executions["BD"])
    page.locator('.jog-btn[data-axis="3"][data-direction="+"]').dispatch_event("pointerdown")
    expect(page.locator("#jog-state")).to_contain_text("Moved axis 3 by +1")
    wait_until(lambda: not stack.in_sim(lambda c: c.model.channels[0].moving))
    after = joints(stack)
    assert stack.in_sim(lambda c: c.executions["BD"]) == moves_before + 1  # one BD per press
    assert after[2] == pytest.approx(start[2] + 1.0, abs=1e-6)
    assert after[:2] == pytest.approx(start[:2]) and after[3] == pytest.approx(start[3])
    page.keyboard.press("3")  # the 0.1 step, from the keyboard
    page.keyboard.press("a")  # axis 1 -
    expect(page.locator("#jog-state")).to_contain_text("Moved axis 1 by -0.1")
    wait_until(lambda: not stack.in_sim(lambda c: c.model.channels[0].moving))
    assert joints(stack)[0] == pytest.approx(after[0] - 0.1, abs=1e-6)


def test_teach_here_writes_the_point(page: Any, stack: Stack, servo_on: None) -> None:
    sign_in(page, "erin")
    page.goto("/line/cell1/jog")
    page.fill("#teach-file", "TAUT.PNT")
    page.fill("#teach-number", "7")
    expect(page.locator("#teach-btn")).to_have_text("Teach here as point 7")
    here = joints(stack)
    page.click("#teach-btn")
    confirm(page, "point 7 of TAUT.PNT")
    expect(page.locator("#toast")).to_contain_text("Point 7 of TAUT.PNT")
    with Client(stack.sim.url) as n1:  # read back through the N1 protocol
        content = n1.execute(DownloadFile(1, "TAUT.PNT", CoordSystem.ANGLE))
    assert isinstance(content, PointFile)
    assert content.points[7].axes == pytest.approx(here, abs=1e-3)
    entries = [json.loads(text) for text in stack.audit_path.read_text().splitlines()]
    taught = [e for e in entries if e["what"].startswith("teach here: point 7 of TAUT.PNT")]
    assert taught and taught[-1]["who"] == "erin"
