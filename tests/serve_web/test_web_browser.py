"""The dashboard in a real browser (Playwright driving Debian's Chromium) against the simulator."""

from __future__ import annotations

import socket
from typing import Any
from urllib.parse import urlsplit

from web_harness import Stack, confirm, expect, sign_in, wait_until


def test_roles_decide_what_the_page_offers(page: Any, stack: Stack) -> None:
    page.goto("/line/cell1")
    assert page.locator("#who").inner_text().startswith("read-only")
    assert page.locator(".operator-only").first.is_hidden()
    sign_in(page, "vic")
    page.goto("/line/cell1")
    assert page.locator(".operator-only").first.is_hidden()
    page.click("header form.inline button")  # sign out
    sign_in(page, "olga")
    page.goto("/line/cell1")
    assert "olga (operator)" in page.locator("#who").inner_text()
    assert page.locator(".operator-only").first.is_visible()


def test_a_lamp_follows_the_controller_live(page: Any, stack: Stack) -> None:
    page.goto("/line/cell1")
    lamp = page.locator('[data-key="cell1/ch2/status"] [data-field="servo_on"]').first
    expect(lamp).to_have_class("lamp servo_on off")
    stack.in_sim(lambda c: setattr(c.model.channels[1], "servo", True))
    try:
        expect(lamp).to_have_class("lamp servo_on on", timeout=5_000)
    finally:
        stack.in_sim(lambda c: setattr(c.model.channels[1], "servo", False))
    expect(lamp).to_have_class("lamp servo_on off", timeout=5_000)


def test_an_output_is_switched_after_confirmation(page: Any, stack: Stack) -> None:
    sign_in(page, "olga")
    page.goto("/line/cell1")
    contact = page.locator('button[data-action="output"][data-port="0"][data-contact="5"]')
    contact.click()
    confirm(page, "Switch output 0.5 ON?")
    wait_until(lambda: stack.in_sim(lambda c: c.model.outputs[0][5]))
    expect(contact).to_have_class("contact on", timeout=5_000)


def test_a_cancelled_confirmation_sends_nothing(page: Any, stack: Stack) -> None:
    sign_in(page, "olga")
    page.goto("/line/cell1")
    before = stack.in_sim(lambda c: c.executions["GC"])
    page.locator('button[data-action="output"][data-port="0"][data-contact="6"]').click()
    page.locator("#confirm").wait_for(state="visible")
    page.click("#confirm button[value=cancel]")
    # a barrier instead of a pause: a switch confirmed after it reaches the controller, and
    # it is the only one (the page sends in order: a cancelled switch sent would be before it)
    page.locator('button[data-action="output"][data-port="0"][data-contact="7"]').click()
    confirm(page, "Switch output 0.7 ON?")
    wait_until(lambda: stack.in_sim(lambda c: c.model.outputs[0][7]))
    assert stack.in_sim(lambda c: c.executions["GC"]) == before + 1
    assert not stack.in_sim(lambda c: c.model.outputs[0][6])


def test_a_jog_stops_when_the_keepalive_stops(page: Any, stack: Stack) -> None:
    stack.in_sim(lambda c: setattr(c.model.channels[0], "servo", True))
    sign_in(page, "olga")
    page.goto("/line/cell1/jog")
    assert page.locator("#no-enabling-device").is_visible()
    stops_before = stack.in_sim(lambda c: c.executions["BG"])
    button = page.locator('.jog-btn[data-axis="1"][data-direction="+"]')
    button.dispatch_event("pointerdown")
    expect(page.locator("#jog-state")).to_contain_text("Moving", timeout=5_000)
    page.evaluate(
        "window.robostarJog.stopKeepalive()"
    )  # a frozen page: no release, no more keepalives
    expect(page.locator("#jog-state")).to_contain_text("keepalives", timeout=5_000)
    assert stack.in_sim(lambda c: c.executions["BG"]) == stops_before + 1
    stack.in_sim(lambda c: setattr(c.model.channels[0], "servo", False))


def test_a_frozen_browser_does_not_slow_the_others(page: Any, stack: Stack) -> None:
    host, port = urlsplit(stack.url).hostname, urlsplit(stack.url).port
    frozen = socket.create_connection((host, port))
    frozen.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    frozen.sendall(f"GET /events HTTP/1.1\r\nHost: {host}:{port}\r\n\r\n".encode())
    try:
        page.goto("/line/cell1")
        contact = page.locator('[data-key="cell1/io/in/2"] [data-contact="7"]')
        for on in (True, False, True, False):  # the frozen reader's buffers fill meanwhile
            stack.in_sim(lambda c, on=on: c.model.set_input(2, 7, on))
            expect(contact).to_have_class(f"contact {'on' if on else 'off'}", timeout=5_000)
    finally:
        frozen.close()


def test_an_upload_is_previewed_then_written(page: Any, stack: Stack, tmp_path: Any) -> None:
    job = tmp_path / "pick.job"
    job.write_text("MAIN\nMOVJ P0001\nMOVJ P0002\nEOP\n")
    sign_in(page, "erin")
    page.goto("/line/cell1/files?channel=1")
    page.set_input_files("#upload-form input[type=file]", str(job))
    page.fill("#upload-form input[name=name]", "PICK.JOB")
    page.click("#upload-form button[type=submit]")
    expect(page.locator("#preview")).to_contain_text("MOVJ P0002")
    names = stack.in_sim(lambda c: [str(f.name) for f in c.model.channels[0].files])
    assert not any("PICK" in name for name in names)
    page.click("#confirm-upload")
    expect(page.locator("table.files")).to_contain_text("PICK.JOB")
