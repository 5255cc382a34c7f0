"""Who has control, on every page: each line's lease (free, or its holder and the seconds left),
"Take control" for an operator when it is free, "Release" for its holder only; a take is
audited, and while one user holds the line another's writes are refused naming the holder."""

from __future__ import annotations

import json
import re
from typing import Any

import httpx
from web_harness import PASSWORDS, Stack, login


def lease_of(page: str) -> str:
    match = re.search(r'data-lease="cell1">.*?<span class="lease-state">([^<]*)</span>', page, re.S)
    assert match, "no lease on the page"
    return match.group(1).strip()


def test_every_page_says_who_has_control(stack: Stack, client: httpx.Client) -> None:
    for path in ("/", "/line/cell1", "/line/cell1/jog", "/audit", "/health", "/login"):
        assert lease_of(client.get(path).text) == "control free", path


def test_take_and_release_by_role(stack: Stack) -> None:
    with (
        httpx.Client(base_url=stack.url, timeout=10) as olga,
        httpx.Client(base_url=stack.url, timeout=10) as erin,
        httpx.Client(base_url=stack.url, timeout=10) as vic,
    ):
        olga_token, erin_token, vic_token = (
            login(olga, "olga"),
            login(erin, "erin"),
            login(vic, "vic"),
        )
        assert (
            vic.post("/line/cell1/lease/take", headers={"x-csrf-token": vic_token}).status_code
            == 403
        )
        assert olga.post("/line/cell1/lease/take").status_code == 403  # no token
        taken = olga.post("/line/cell1/lease/take", headers={"x-csrf-token": olga_token})
        assert taken.status_code == 200 and taken.json()["lease"]["mine"]
        seen = lease_of(erin.get("/health").text)
        assert seen.startswith("control held by olga (web)") and "s left" in seen
        rows = erin.get("/leases").json()["leases"]
        assert rows[0]["holder"] == "olga (web)" and not rows[0]["mine"] and not rows[0]["may_take"]
        again = erin.post("/line/cell1/lease/take", headers={"x-csrf-token": erin_token})
        assert again.status_code == 409 and "olga" in again.json()["error"]
        body = {"action": "speed", "channel": 1, "percent": 50, "confirmed": True}
        refused = erin.post("/line/cell1/action", json=body, headers={"x-csrf-token": erin_token})
        assert refused.status_code == 409 and "held by olga (web)" in refused.json()["error"]
        released = erin.post("/line/cell1/release", headers={"x-csrf-token": erin_token})
        assert released.json()["released"] is False  # not the holder
        released = olga.post("/line/cell1/release", headers={"x-csrf-token": olga_token})
        assert released.json()["released"] is True
        assert lease_of(erin.get("/").text) == "control free"
    entries = [json.loads(t) for t in stack.audit_path.read_text().splitlines()]
    assert any(e["what"].startswith("lease take") and e["who"] == "olga" for e in entries)


def test_take_and_release_in_the_browser(page: Any, stack: Stack) -> None:
    from playwright.sync_api import expect

    page.goto("/login")
    page.fill("input[name=username]", "olga")
    page.fill("input[name=password]", PASSWORDS["olga"])
    page.click("form.login button[type=submit]")
    page.wait_for_url("**/")
    lease = page.locator('[data-lease="cell1"]')
    lease.locator(".lease-take").click()
    expect(lease.locator(".lease-state")).to_contain_text("held by olga (web)")
    expect(lease.locator(".lease-take")).to_be_hidden()
    lease.locator(".lease-release").click()
    expect(lease.locator(".lease-state")).to_have_text("control free")
    assert stack.line.lease.holder is None
