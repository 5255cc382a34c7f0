"""GETs that hold the line for file transfers (FA): the backup zip, a file's page and its
download. A GET carries no CSRF token and any page the operator opens can fire one, so they
need a signed-in user, and a line serves one such transfer at a time: browsers cannot queue
transfer after transfer ahead of a host program's writes."""

from __future__ import annotations

import io
import json
import zipfile
from concurrent.futures import ThreadPoolExecutor

import httpx
import pytest
from web_harness import Stack, login, wait_until

TRANSFERS = (
    "/line/cell1/backup.zip",
    "/line/cell1/files/1/DEMO.JOB",
    "/line/cell1/files/1/DEMO.JOB/download",
)


@pytest.mark.parametrize("path", TRANSFERS)
def test_an_anonymous_transfer_is_refused_before_the_line_is_used(
    stack: Stack, client: httpx.Client, path: str
) -> None:
    exchanges = stack.line.health.exchanges
    answer = client.get(path)
    assert answer.status_code == 403, answer.text
    assert "viewer role; sign in first" in answer.json()["error"]
    # what a cross-site <img src=...> gets: the page, in a browser that asks for HTML
    page = client.get(path, headers={"accept": "text/html"})
    assert page.status_code == 403 and "sign in first" in page.text
    # the poller's reads go on; no FA went out for the visitor (a few AA/BA at most)
    assert stack.line.health.exchanges - exchanges < 50
    entries = [json.loads(text) for text in stack.audit_path.read_text().splitlines()]
    refused = [e for e in entries if e["who"] == "anonymous" and e["outcome"].startswith("refused")]
    assert refused and "viewer role" in refused[-1]["outcome"]


def test_a_viewer_may_back_up_view_and_download(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        login(http, "vic")
        backup = http.get("/line/cell1/backup.zip")
        assert backup.status_code == 200, backup.text
        assert "ch1/DEMO.JOB" in zipfile.ZipFile(io.BytesIO(backup.content)).namelist()
        assert http.get("/line/cell1/files/1/DEMO.JOB").status_code == 200
        download = http.get("/line/cell1/files/1/DEMO.JOB/download")
        assert download.status_code == 200, download.text
        assert download.headers["content-disposition"] == 'attachment; filename="DEMO.JOB"'


def test_one_transfer_at_a_time_per_line(stack: Stack) -> None:
    transferring: set[str] = stack.face.app.state.transferring
    with (
        httpx.Client(base_url=stack.url, timeout=30.0) as first,
        httpx.Client(base_url=stack.url, timeout=30.0) as second,
        ThreadPoolExecutor(1) as pool,
    ):
        login(first, "vic")
        login(second, "olga")
        with stack.sim.lock:  # the simulator answers nothing while this is held
            backup = pool.submit(first.get, "/line/cell1/backup.zip")
            wait_until(lambda: "cell1" in transferring, what="the backup's start")
            answers = [second.get(path) for path in TRANSFERS]
        assert [a.status_code for a in answers] == [429, 429, 429]
        assert "a backup or file download is already running" in answers[0].json()["error"]
        assert backup.result(30).status_code == 200
        assert "cell1" not in transferring
        # done: the next one is served
        assert second.get("/line/cell1/files/1/DEMO.JOB/download").status_code == 200


def test_the_file_list_is_read_from_the_controller_only_for_a_signed_in_user(
    stack: Stack, client: httpx.Client
) -> None:
    page = client.get("/line/cell1/files")  # the page, for everyone; no FD for a visitor
    assert page.status_code == 200
    assert "Sign in to list the files" in page.text and "DEMO.JOB" not in page.text
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        login(http, "vic")
        assert "DEMO.JOB" in http.get("/line/cell1/files").text
        transferring: set[str] = stack.face.app.state.transferring
        transferring.add("cell1")  # as while a backup runs
        try:
            busy = http.get("/line/cell1/files")
        finally:
            transferring.discard("cell1")
        assert busy.status_code == 200
        assert "a backup or file download is already running" in busy.text
