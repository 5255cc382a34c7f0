"""The JSON tree as a Unified Namespace: positions as named axes with units, one
topic per I/O signal beside the port, only the controller's channels, an unknown command named
unknown, live (not historical) first values and one ``online true`` after ``info`` at a start
with the broker up, and the retained values marked ``offline`` after a clean stop."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest

from robostar.serve import LineConfig, LineServer, ServeConfig

from .conftest import Broker, Requester, serving, until
from .test_mqtt_face import Collector, _subscribe

pytestmark = pytest.mark.timeout(120)

ROOT = "robostar/cell1"


def _server(broker: Broker) -> LineServer:
    return LineServer(
        ServeConfig(
            lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=0.05),),
            faces={"mqtt": {"url": broker.url}},
        )
    )


async def _run_once(broker: Broker) -> Collector:
    """A start with the broker up, until the values are out, then a clean stop."""
    sub, task = await _subscribe(broker)
    async with _server(broker) as server:
        link: Any = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
        await until(lambda: link.client is not None)
        await until(lambda: sub.values(f"{ROOT}/io/in/0/15") != [])
        await until(lambda: sub.values(f"{ROOT}/online") != [])
    await until(lambda: sub.values(f"{ROOT}/online")[-1:] == [False])
    await asyncio.sleep(0.3)  # the offline values
    task.cancel()
    return sub


def test_values_for_a_unified_namespace(broker: Broker) -> None:
    sub = asyncio.run(_run_once(broker))
    position = sub.values(f"{ROOT}/ch1/position")[0]["value"]
    assert position["x"] == {"value": 600.0, "unit": "mm"}
    assert position["r"]["unit"] == "deg" and position["arm"] == "right"
    angles = sub.values(f"{ROOT}/ch1/angles")[0]["value"]
    assert angles["j1"]["unit"] == "deg" and angles["j3"]["unit"] == "mm"  # a SCARA
    port = sub.values(f"{ROOT}/io/in/0")[0]["value"]
    assert len(port["contacts"]) == 16  # the port array stays
    assert sub.values(f"{ROOT}/io/in/0/3")[0]["value"] is False
    # Only the channels the controller has (the simulator has 2; the model knows a 3rd).
    assert not [t for t, _, _ in sub.messages if t.startswith(f"{ROOT}/ch3/")]


def test_a_start_is_live_and_born_once_a_clean_stop_says_offline(broker: Broker) -> None:
    sub = asyncio.run(_run_once(broker))
    live = [(t, p) for t, p, _ in sub.messages if isinstance(p, dict)]
    historical = [t for t, p in live if p.get("historical")]
    assert historical == []  # the broker was up: nothing waited, nothing is history
    topics = [t for t, _, _ in sub.messages]
    online = [p for t, p, _ in sub.messages if t == f"{ROOT}/online"]
    assert online == [True, False]
    assert topics.index(f"{ROOT}/info") < topics.index(f"{ROOT}/online")
    # After the stop, each value is said again, retained, no longer vouched for.
    offline = sub.values(f"{ROOT}/ch1/status")[-1]
    assert offline["quality"] == "offline"
    assert sub.values(f"{ROOT}/io/in/0/15")[-1]["quality"] == "offline"


def test_an_unknown_command_is_named_unknown(broker: Broker, tmp_path: Path) -> None:
    async def main() -> None:
        async with serving(broker, tmp_path / "audit.jsonl"), Requester.connect(broker) as req:
            await req.send("fly", b'{"id": 1}')
            await req.send("output", b'{"id": 2}')  # known, not allowed
            await until(lambda: req.by_id(1) != [] and req.by_id(2) != [])
            assert "unknown command 'fly'" in req.by_id(1)[0][1]["error"]
            assert "not enabled" in req.by_id(2)[0][1]["error"]

    asyncio.run(main())
