"""Programs under change control through the dashboard: an upload is kept as a version (who,
when, how), reading the same text again adds none, a change made at the pendant is flagged by
the check and shown as a line diff, and "restore this version" (engineer, preview, confirm)
writes the old text back, audited. Also in Chromium: the diff and the restore."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from web_harness import PASSWORDS, Stack, login

from robostar.client.sync import Client
from robostar.commands.files import DownloadFile
from robostar.protocol.fields import FileName
from robostar.sim.filesystem import StoredJob
from robostar.types import CoordSystem, JobFile


def upload(http: httpx.Client, token: str, name: str, text: str, number: int) -> None:
    form = {"csrf_token": token, "channel": "1", "name": name, "job_number": str(number)}
    answer = http.post(
        "/line/cell1/files/upload/confirm",
        data={**form, "content": text, "confirmed": "yes"},
        follow_redirects=False,
    )
    assert answer.status_code == 303, answer.text


def at_the_pendant(stack: Stack, name: str, number: int, lines: list[str]) -> None:
    """An edit made on the controller itself (not through the server)."""
    stored = StoredJob(FileName.parse(name), number, lines)
    stack.in_sim(lambda c: c.model.channels[0].files.put(stored))


def n1_lines(stack: Stack, name: str) -> tuple[str, ...]:
    with Client(stack.sim.url) as n1:
        content = n1.execute(DownloadFile(1, name, CoordSystem.ANGLE))
    assert isinstance(content, JobFile)
    return content.lines


def test_an_upload_is_kept_and_a_pendant_edit_is_flagged_and_restored(stack: Stack) -> None:
    first = "MAIN\nMOVJ P0001\nDELAY 10\nEOP\n"
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        token = login(http, "erin")
        upload(http, token, "CTL.JOB", first, 41)
        page = http.get("/line/cell1/files/1/CTL.JOB/versions").text
        assert page.count('<tr data-hash="') == 1 and "erin (web)" in page and "upload" in page
        http.get("/line/cell1/files/1/CTL.JOB")  # read back: the same text, no new version
        assert http.get("/line/cell1/files/1/CTL.JOB/versions").text.count("<tr data-hash") == 1

        at_the_pendant(stack, "CTL.JOB", 41, ["MAIN", "MOVJ P0001", "DELAY 99", "EOP"])
        check = http.post("/line/cell1/programs/check", data={"csrf_token": token}).text
        assert re.search(r"CTL\.JOB</td>\s*<td>CHANGED outside the server", check)
        assert "DEMO.JOB</td>" in check
        versions = http.get("/line/cell1/files/1/CTL.JOB/versions").text
        hashes = re.findall(r'<tr data-hash="([0-9a-f]+)"', versions)
        assert len(hashes) == 2  # the pendant's text kept by the check
        newest, oldest = hashes
        diff = http.get(f"/line/cell1/files/1/CTL.JOB/versions?a={oldest}&b={newest}").text
        assert '<span class="del">-DELAY 10</span>' in diff
        assert '<span class="add">+DELAY 99</span>' in diff

        with httpx.Client(base_url=stack.url, timeout=30.0) as olga:
            olga_token = login(olga, "olga")
            refused = olga.post(
                "/line/cell1/files/1/CTL.JOB/versions/restore/confirm",
                data={"csrf_token": olga_token, "version": oldest, "confirmed": "yes"},
            )
            assert refused.status_code == 403
        preview = http.post(
            "/line/cell1/files/1/CTL.JOB/versions/restore",
            data={"csrf_token": token, "version": oldest},
        ).text
        assert '<span class="add">+DELAY 10</span>' in preview
        assert n1_lines(stack, "CTL.JOB")[2] == "DELAY 99"  # a preview writes nothing
        done = http.post(
            "/line/cell1/files/1/CTL.JOB/versions/restore/confirm",
            data={"csrf_token": token, "version": oldest, "confirmed": "yes"},
            follow_redirects=False,
        )
        assert done.status_code == 303
    assert n1_lines(stack, "CTL.JOB") == ("MAIN", "MOVJ P0001", "DELAY 10", "EOP")
    entries = [json.loads(t) for t in stack.audit_path.read_text().splitlines()]
    restored = [e for e in entries if e["what"].startswith("restore CTL.JOB on channel 1")]
    assert restored and restored[-1]["who"] == "erin" and oldest[:10] in restored[-1]["what"]
    kept = stack.audit_path.parent / "programs"
    assert any(kept.joinpath("blobs").rglob(oldest))  # beside the audit log, by hash


def test_the_check_needs_the_pages_token(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        login(http, "vic")
        assert http.post("/line/cell1/programs/check").status_code == 403


@pytest.fixture
def page(chromium: Any, stack: Stack) -> Iterator[Any]:
    context = chromium.new_context(base_url=stack.url)
    tab = context.new_page()
    tab.set_default_timeout(15_000)
    try:
        yield tab
    finally:
        context.close()


def test_the_diff_and_the_restore_in_the_browser(page: Any, stack: Stack) -> None:
    from playwright.sync_api import expect

    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        upload(http, login(http, "erin"), "BRW.JOB", "MAIN\nDELAY 5\nEOP\n", 42)
    at_the_pendant(stack, "BRW.JOB", 42, ["MAIN", "DELAY 6", "EOP"])
    page.goto("/login")
    page.fill("input[name=username]", "erin")
    page.fill("input[name=password]", PASSWORDS["erin"])
    page.click("form.login button[type=submit]")
    page.wait_for_url("**/")
    page.goto("/line/cell1/files/1/BRW.JOB/versions")
    page.select_option("select[name=b]", "current")  # the last version vs the controller now
    page.click("#diff-form button[type=submit]")
    expect(page.locator("#diff .del")).to_have_text("-DELAY 5")
    expect(page.locator("#diff .add")).to_have_text("+DELAY 6")
    # the upload's version (the diff kept the pendant's text as a version of its own)
    page.locator("tr[data-hash]", has_text="upload").locator("button.restore").click()
    expect(page.locator("#restore-diff .add")).to_have_text("+DELAY 5")
    page.check("input[name=confirmed]")
    page.click("#confirm-restore")
    expect(page.locator("#restored")).to_contain_text("written back")
    assert n1_lines(stack, "BRW.JOB") == ("MAIN", "DELAY 5", "EOP")
