"""The command size cap before a message is in memory: the face tells the broker its MQTT 5
Maximum Packet Size on CONNECT, so the broker drops a command far over ``max_payload`` instead
of sending it (a flood of 4 MiB messages took the face from 41 to 418 MiB)."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from robostar.serve.faces.mqtt import MqttFace, settings_from

from .conftest import Broker, Requester, serving, until

pytestmark = pytest.mark.timeout(120)


def _audit(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_the_face_announces_its_maximum_packet_size() -> None:
    async def main() -> Any:
        options = {"url": "mqtt://127.0.0.1", "commands": {"max_payload": 1000}}
        face = MqttFace(None, settings_from(options))  # type: ignore[arg-type]
        return face.client("x", "robostar/x/online")._properties

    properties = asyncio.run(main())
    assert properties.MaximumPacketSize == 1000 + 65_535 + 64


def test_a_command_far_over_the_limit_never_reaches_the_face(
    broker: Broker, tmp_path: Path
) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with serving(broker, audit) as (_, link), Requester.connect(broker) as req:
            big = b'{"channel": 1, "value": 5, "pad": "' + b"x" * (1 << 20) + b'"}'
            await req.send("speed", big, correlation=b"big")
            await req.send("speed", b'{"channel": 1, "value": 6, "id": "small"}')
            await until(lambda: req.by_id("small") != [])
            await asyncio.sleep(0.5)
            assert not any(r[2] == b"big" for r in req.replies)  # dropped by the broker
            assert link.client is not None  # and the face is still connected
        assert not any("over the limit" in e["outcome"] for e in _audit(audit))

    asyncio.run(main())
