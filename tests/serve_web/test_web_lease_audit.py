"""The dashboard's lease release is in the audit log, as the API's is."""

from __future__ import annotations

import json

import httpx
from web_harness import Stack, login

from robostar.serve.lease import Who


async def _take(stack: Stack, who: Who) -> None:
    stack.line.lease.acquire(who, 300.0)


def test_a_lease_release_from_the_dashboard_is_audited(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        token = login(http, "olga")
        body = {"action": "speed", "channel": 1, "speed": 40, "confirmed": True}
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 200, answer.text
        assert stack.line.lease.holder is None  # a click takes control for itself only
        stack.call(_take(stack, Who("olga", "web")))  # olga takes control for a sequence
        released = http.post("/line/cell1/release", headers={"x-csrf-token": token})
        assert released.json() == {"ok": True, "released": True}
        again = http.post("/line/cell1/release", headers={"x-csrf-token": token})
        assert again.json() == {"ok": True, "released": False}
    entries = [json.loads(text) for text in stack.audit_path.read_text().splitlines()]
    releases = [
        (e["who"], e["face"], e["outcome"]) for e in entries if e["what"] == "lease release"
    ]
    assert releases == [
        ("olga", "web", "ok"),
        ("olga", "web", "not held: nothing released"),
    ]
