"""Running the cell from the controller page in Chromium: Home per channel, selecting a job from
the channel's JOB files (by name and number), a step in step mode and a stop, each confirmed."""

from __future__ import annotations

from typing import Any

from web_harness import Stack, confirm, expect, sign_in, wait_until


def test_home_then_select_a_job_and_step_it(page: Any, stack: Stack) -> None:
    sign_in(page, "olga")
    page.goto("/line/cell1")
    card = page.locator(".channel-card[data-channel='1']")
    homes = stack.in_sim(lambda c: c.executions["BA"])
    card.locator('button[data-action="home"]').click()
    confirm(page, "Home channel 1")
    wait_until(lambda: stack.in_sim(lambda c: c.model.channels[0].origin))
    assert stack.in_sim(lambda c: c.executions["BA"]) == homes + 1
    wait_until(lambda: not stack.in_sim(lambda c: c.model.channels[0].moving))

    select = card.locator(".job-select")
    select.focus()
    expect(select.locator("option", has_text="1: DEMO.JOB")).to_have_count(1)
    select.select_option("DEMO.JOB")
    card.locator('button[data-action="job_select"]').click()
    confirm(page, "Select DEMO.JOB on channel 1?")
    wait_until(lambda: str(stack.in_sim(lambda c: c.model.channels[0].job_name)) == "DEMO.JOB")
    expect(card.locator('[data-key="cell1/ch1/job"]')).to_contain_text("DEMO")

    card.locator('button[data-action="job_step"]').click()
    confirm(page, "Run one step")
    wait_until(lambda: stack.in_sim(lambda c: c.executions["CC"]) >= 1)
    card.locator('button[data-action="job_stop"]').click()
    confirm(page, "Stop the job")
    wait_until(lambda: not stack.in_sim(lambda c: c.model.channels[0].running))
    card.locator('button[data-action="job_auto"]').click()
    confirm(page, "auto mode")
    expect(page.locator("#toast")).to_contain_text("job_auto: done")
    entries = stack.audit_path.read_text(encoding="utf-8")
    assert '"who": "olga"' in entries and "SelectJob" in entries and "Home" in entries
    stack.in_sim(lambda c: setattr(c.model.channels[0], "servo", False))
