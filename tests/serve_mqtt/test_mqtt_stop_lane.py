"""A stop behind a flood: thousands of ordinary commands, then one ``estop``. The stop has
its own MQTT connection and queue, and the reader never waits on a refusal's answer, so the
E-stop runs within a second or two however many commands are refused busy."""

from __future__ import annotations

import asyncio
import json
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from .conftest import Broker, serving

pytestmark = pytest.mark.timeout(120)

FLOOD = """
import asyncio, json, sys, aiomqtt
async def main():
    async with aiomqtt.Client("127.0.0.1", int(sys.argv[1]),
            protocol=aiomqtt.ProtocolVersion.V5, max_queued_outgoing_messages=None) as c:
        for i in range(int(sys.argv[2])):
            body = {"channel": 1, "value": 100 + i % 50, "id": i}
            await c.publish("robostar/cell1/cmd/speed", json.dumps(body).encode(), qos=1)
        await c.publish("robostar/cell1/cmd/estop", b'{"id": "estop"}', qos=1)
    print("sent", flush=True)
asyncio.run(main())
"""


def _audit(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_an_estop_behind_a_flood_of_commands_runs(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with serving(broker, audit, estop=True, max_pending=4) as (_, link):
            flood = await asyncio.create_subprocess_exec(
                sys.executable, "-c", FLOOD, str(broker.port), "3000",
                stdout=asyncio.subprocess.PIPE,
            )  # fmt: skip
            assert flood.stdout is not None
            assert (await flood.stdout.readline()).strip() == b"sent"
            await flood.wait()
            sent = time.monotonic()
            stops: list[dict[str, Any]] = []
            while time.monotonic() - sent < 10 and not stops:
                stops = [e for e in _audit(audit) if "EmergencyStop" in e["what"]]
                await asyncio.sleep(0.05)
            assert stops, "the E-stop never ran"
            assert stops[0]["outcome"] == "ok"
            assert time.monotonic() - sent < 5
            # The readers and workers are all still there.
            assert link.client is not None and not any(w.done() for w in link.workers)

    asyncio.run(main())
