"""Who had control when is part of the record: taking, renewing, releasing the lease over the
API and being refused it (409) each leave an audit entry."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import httpx

from robostar.serve import LineConfig, LineServer, ServeConfig


def test_lease_take_renew_refusal_and_release_are_audited(tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.5),),
        faces={"api": {"listen": "127.0.0.1:0"}},
        audit_path=str(audit),
    )

    async def main() -> list[int]:
        async with LineServer(config) as server:
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            url = f"http://{host}:{port}/lines/cell1/lease"
            ann, bob = {"x-robostar-who": "ann"}, {"x-robostar-who": "bob"}
            json_type = {"content-type": "application/json"}
            async with httpx.AsyncClient(timeout=10) as http:
                answers = [
                    await http.post(f"{url}?ttl=3600", headers={**ann, **json_type}),
                    await http.post(url, headers={**ann, **json_type}),
                    await http.post(url, headers={**bob, **json_type}),
                    await http.delete(url, headers={**bob, **json_type}),
                    await http.delete(url, headers={**ann, **json_type}),
                ]
            return [a.status_code for a in answers]

    assert asyncio.run(main()) == [200, 200, 409, 200, 200]
    entries = [json.loads(text) for text in audit.read_text().splitlines()]
    seen = [(e["who"], e["face"], e["what"], e["outcome"].split(":")[0]) for e in entries]
    assert seen == [
        ("ann", "api", "lease take", "ok"),
        ("ann", "api", "lease renew", "ok"),
        ("bob", "api", "lease take", "refused"),
        ("bob", "api", "lease release", "not held"),
        ("ann", "api", "lease release", "ok"),
    ]
    assert entries[0]["outcome"] == "ok: expires in 3600 s unless renewed"
    assert "control is held by ann (api)" in entries[2]["outcome"]
    assert all(e["line"] == "cell1" for e in entries)
