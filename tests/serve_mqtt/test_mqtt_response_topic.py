"""A request's response topic inside the face's own tree: the face would publish its answer
there itself, and take it as a command (an E-stop nobody sent; a client allowed only one line's
``cmd/speed`` stopping another line). Refused and audited, as any bad response topic."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from robostar.commands.control import ReadSpeed
from robostar.serve.faces.mqtt.topics import response_topic_problem

from .conftest import Broker, Requester, serving, until

pytestmark = pytest.mark.timeout(120)


def _audit(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_a_response_topic_in_the_faces_own_tree_is_refused(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with (
            serving(broker, audit, estop=True) as (server, _),
            Requester.connect(broker) as req,
        ):
            for n, topic in enumerate(("robostar/cell1/cmd/estop", "robostar/cell2/cmd/estop")):
                body = {"channel": 1, "value": 211, "id": n}
                await req.send("speed", json.dumps(body).encode(), response_topic=topic)
                await until(lambda: req.by_id(n) != [])  # noqa: B023
                [(where, reply, _)] = req.by_id(n)
                assert where == "robostar/cell1/cmd/speed/result"
                assert reply["ok"] is False and "own tree" in reply["error"]
            await req.send("estop", b'{"id": "e"}', response_topic="robostar/cell1/cmd/estop")
            await until(lambda: req.by_id("e") != [])
            await asyncio.sleep(0.5)
            assert await server.lines["cell1"].read(ReadSpeed(1), max_age=0) != 211
        entries = _audit(audit)
        assert not any("EmergencyStop" in e["what"] for e in entries), entries
        assert len(entries) == 3 and all("own tree" in e["outcome"] for e in entries), entries

    asyncio.run(main())


@pytest.mark.parametrize(
    ("topic", "refused"),
    [
        ("robostar", True),
        ("robostar/cell1/cmd/estop", True),
        ("robostar/_server/online", True),
        ("robostarx/replies", False),
        ("replies/robostar/cell1", False),
    ],
)
def test_the_own_tree_rule(topic: str, refused: bool) -> None:
    problem = response_topic_problem(topic, "robostar")
    assert (problem is not None and "own tree" in problem) is refused
