"""Retained command messages: a command left retained in the broker must not run at every
(re)connect of the face, and the empty retained publish that clears one must not run an E-stop."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import aiomqtt
import pytest

from robostar.commands.control import ReadSpeed
from robostar.errors import UsageError
from robostar.serve.faces.mqtt.commands import read_params

from .conftest import Broker, Requester, serving, until

pytestmark = pytest.mark.timeout(120)


def _audit(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines()]


async def _publish_retained(broker: Broker, topic: str, payload: bytes) -> None:
    async with aiomqtt.Client(
        "127.0.0.1", broker.port, protocol=aiomqtt.ProtocolVersion.V5
    ) as client:
        await client.publish(topic, payload, qos=1, retain=True)


def test_a_retained_command_never_runs_and_clearing_one_is_no_estop(
    broker: Broker, tmp_path: Path
) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        # Left retained before the server starts (a dashboard's "retain" ticked by mistake).
        await _publish_retained(broker, "robostar/cell1/cmd/speed", b'{"channel": 1, "value": 301}')
        for _ in range(2):  # a start, then a restart of the line server
            async with serving(broker, audit, estop=True) as (server, _):
                await asyncio.sleep(1.0)
                speed = await server.lines["cell1"].read(ReadSpeed(1), max_age=0)
                assert speed != 301
        assert not any(e["outcome"] == "ok" for e in _audit(audit))

        async with serving(broker, audit, estop=True), Requester.connect(broker) as req:
            # A retained command published while the face is connected: refused and audited.
            await _publish_retained(
                broker, "robostar/cell1/cmd/speed", b'{"channel": 1, "value": 302, "id": "r"}'
            )
            await until(lambda: req.by_id("r") != [])
            reply = req.by_id("r")[0][1]
            assert reply["ok"] is False and "retain" in reply["error"]
            # Clearing a retained estop (an empty retained publish) is no E-stop ...
            await _publish_retained(broker, "robostar/cell1/cmd/estop", b"")
            # ... nor is an empty command message (it is not "{}").
            await req.send("estop", b"", correlation=b"empty")
            await until(lambda: any(r[2] == b"empty" for r in req.replies))
            [empty] = [r[1] for r in req.replies if r[2] == b"empty"]
            assert empty["ok"] is False and empty["error"].startswith("bad payload")
            await until(lambda: len(_audit(audit)) >= 3)
            await asyncio.sleep(0.5)
        entries = _audit(audit)
        assert not any(e["outcome"] == "ok" for e in entries), entries
        assert not any("EmergencyStop" in e["what"] for e in entries), entries
        refused = [e["outcome"] for e in entries]
        assert len(refused) == 3 and all(o.startswith("refused: ") for o in refused), refused
        assert sum("retain" in o for o in refused) == 2

    asyncio.run(main())


def test_an_empty_payload_is_not_an_empty_object() -> None:
    with pytest.raises(UsageError, match="bad payload: empty"):
        read_params(b"")
    assert read_params(b"{}") == {}
