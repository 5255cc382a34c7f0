"""The lease bar's take and release are the line's own calls (Line.take_control,
release_control): one audit entry each, in the line's words, and a refusal names the holder; a
one-shot lease (a click, an MQTT command) is shown as lasting one command, never as control a
user holds and must release."""

from __future__ import annotations

import json
import re

import httpx
from web_harness import Stack, login

from robostar.serve.lease import Who


def lease_of(page: str) -> str:
    match = re.search(r'data-lease="cell1">.*?<span class="lease-state">([^<]*)</span>', page, re.S)
    assert match, "no lease on the page"
    return match.group(1).strip()


def lease_entries(stack: Stack) -> list[tuple[str, str, str]]:
    entries = [json.loads(text) for text in stack.audit_path.read_text().splitlines()]
    return [(e["who"], e["what"], e["outcome"]) for e in entries if e["what"].startswith("lease")]


def test_take_and_release_write_one_entry_each(stack: Stack) -> None:
    with (
        httpx.Client(base_url=stack.url, timeout=10) as olga,
        httpx.Client(base_url=stack.url, timeout=10) as erin,
    ):
        olga_token, erin_token = login(olga, "olga"), login(erin, "erin")
        taken = olga.post("/line/cell1/lease/take", headers={"x-csrf-token": olga_token})
        assert taken.status_code == 200, taken.text
        refused = erin.post("/line/cell1/lease/take", headers={"x-csrf-token": erin_token})
        assert refused.status_code == 409 and "held by olga (web) until" in refused.json()["error"]
        released = olga.post("/line/cell1/lease/release", headers={"x-csrf-token": olga_token})
        assert released.json() == {"ok": True, "released": True}
    entries = lease_entries(stack)
    assert len(entries) == 3, entries
    (take_who, take_what, take_outcome), refusal, release = entries
    assert (take_who, take_what) == ("olga", "lease take")
    assert re.fullmatch(r"ok: until \d\d:\d\d:\d\d UTC", take_outcome), take_outcome
    assert refusal[:2] == ("erin", "lease take") and refusal[2].startswith("refused: ")
    assert "held by olga (web)" in refusal[2]
    assert release == ("olga", "lease release", "ok")
    assert stack.line.lease.holder is None


async def _take_once(stack: Stack, who: Who) -> None:
    stack.line.lease.acquire(who, 30.0, once=True)


def test_a_one_shot_lease_is_shown_as_one_command(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=10) as olga:
        login(olga, "olga")
        stack.call(_take_once(stack, Who("mes", "mqtt")))
        assert lease_of(olga.get("/").text) == "in use by mes (mqtt) for one command"
        row = olga.get("/leases").json()["leases"][0]
        assert row["once"] and row["holder"] == "mes (mqtt)" and not row["may_take"]
        assert "mes (mqtt), for one command" in olga.get("/health").text
