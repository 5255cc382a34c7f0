"""The line's lease over MQTT: who holds it is published retained on ``<prefix>/<line>/control``
(and as Sparkplug metrics ``control/...``), following takes and releases by any face;
``take_control`` / ``release_control`` hold it for a sequence of commands (allowlisted,
audited), during which another consumer is refused; a single command takes a free lease for
itself only, so it never keeps a host program out."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import aiomqtt
import pytest

from robostar.commands.control import SetSpeed
from robostar.errors import RobostarError
from robostar.serve import LineServer, ServeConfig
from robostar.serve.lease import LeaseHeldError, Who

from . import sparkplug_wire as wire
from .conftest import Broker, Requester, serving, until
from .test_mqtt_sparkplug import GROUP, NODE, _by_name, _config, _host

pytestmark = pytest.mark.timeout(120)

ALLOW = ["speed", "take_control", "release_control"]
HOST = Who("host", "n1")
ANN = Who("ann", "api")


class ControlTopic:
    """Every message on ``robostar/cell1/control``, decoded."""

    def __init__(self) -> None:
        self.seen: list[dict[str, Any]] = []

    async def run(self, broker: Broker, ready: asyncio.Event) -> None:
        async with aiomqtt.Client("127.0.0.1", broker.port) as client:
            await client.subscribe("robostar/cell1/control", qos=1)
            ready.set()
            async for message in client.messages:
                raw = message.payload
                assert isinstance(raw, bytes)
                self.seen.append(json.loads(raw))

    def holder(self) -> str | None:
        return self.seen[-1]["value"]["holder"] if self.seen else None


async def _one_shot(line: Any, who: Who) -> bool:
    """Whether ``who``'s single command is carried out (False: refused by the lease)."""
    try:
        await line.execute(SetSpeed(1, 300), who=who, implicit_lease=True)
    except LeaseHeldError:
        return False
    return True


def test_take_and_release_control_over_mqtt(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        watcher, ready = ControlTopic(), asyncio.Event()
        task = asyncio.create_task(watcher.run(broker, ready))
        await asyncio.wait_for(ready.wait(), 10)
        async with (
            serving(broker, audit, allow=ALLOW) as (server, _),
            Requester.connect(broker) as req,
        ):
            line = server.lines["cell1"]
            await until(lambda: watcher.holder() == "")
            assert watcher.seen[-1]["value"]["free"] is True

            async def ask(name: str, params: dict[str, Any], n: int) -> dict[str, Any]:
                await req.send(name, json.dumps({**params, "id": n}).encode())
                await until(lambda: req.by_id(n) != [], 30)
                return req.by_id(n)[0][1]

            # one command: a free lease for itself only, given back as it ends
            assert (await ask("speed", {"channel": 1, "value": 500}, 0))["ok"] is True
            assert line.control().free
            assert await _one_shot(line, HOST)

            bad = await ask("take_control", {"seconds": 0}, 1)
            taken = await ask("take_control", {"seconds": 60}, 2)
            await until(lambda: watcher.holder() == "cell-robostar")
            shown = watcher.seen[-1]["value"]
            host_kept_out = not await _one_shot(line, HOST)
            kept = await ask("speed", {"channel": 1, "value": 400}, 3)  # the holder's: runs
            still = line.control().holder
            released = await ask("release_control", {}, 4)
            await until(lambda: watcher.holder() == "")
            host_again = await _one_shot(line, HOST)

            line.take_control(ANN, 60)  # another face's take shows too, and keeps MQTT out
            await until(lambda: watcher.holder() == "ann")
            refused = await ask("take_control", {}, 5)
            line.release_control(ANN)
            await until(lambda: watcher.holder() == "")
        task.cancel()
        assert bad["ok"] is False and "seconds" in bad["error"]
        assert taken["ok"] is True and taken["result"]["holder"] == "cell-robostar"
        assert shown["face"] == "mqtt" and shown["once"] is False and shown["until"] > 0
        assert host_kept_out
        assert kept["ok"] is True and still == "cell-robostar"
        assert released["ok"] is True and released["result"] == {"released": True}
        assert host_again
        assert refused["ok"] is False and refused["kind"] == "LeaseHeldError"
        assert "ann" in refused["error"]
        entries = [json.loads(line) for line in audit.read_text().splitlines()]
        mine = [(e["what"], e["outcome"][:7]) for e in entries if e["face"] == "mqtt"]
        assert ("lease take", "ok: unt") in mine
        assert ("lease release", "ok") in mine
        assert ("lease take", "refused") in mine
        assert ("cmd/take_control", "refused") in mine  # seconds 0, before the lease

    asyncio.run(main())


def test_take_control_needs_the_allowlist(broker: Broker, tmp_path: Path) -> None:
    async def main() -> None:
        async with (
            serving(broker, tmp_path / "audit.jsonl", allow=["speed"]) as (server, _),
            Requester.connect(broker) as req,
        ):
            await req.send("take_control", b'{"id": 1}')
            await until(lambda: req.by_id(1) != [], 30)
            answer = req.by_id(1)[0][1]
            free = server.lines["cell1"].control().free
        assert answer["ok"] is False and "not enabled" in answer["error"]
        assert free

    asyncio.run(main())


def test_sparkplug_control_metrics_and_take_by_dcmd(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"
    config = _config(broker, commands={"enabled": True, "allow": ALLOW})
    config = ServeConfig(lines=config.lines, faces=config.faces, audit_path=str(audit))

    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(config) as server:
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            line = server.lines["cell1"]
            birth = _by_name(host.of("DBIRTH", "cell1")[-1])
            holder = birth["control/holder"].alias

            def holders() -> list[Any]:
                return [
                    m.value
                    for p in host.of("DDATA", "cell1")
                    for m in p.metrics
                    if m.alias == holder
                ]

            line.take_control(ANN, 60)
            await until(lambda: "ann" in holders())
            line.release_control(ANN)
            await until(lambda: holders()[-1] == "")
            assert host.client is not None
            topic = f"spBv1.0/{GROUP}/DCMD/{NODE}/cell1"
            await host.client.publish(topic, wire.command_request("cmd/take_control", "{}"))
            await until(lambda: holders()[-1] == "robostar")
            try:
                await line.execute(SetSpeed(1, 300), who=HOST, implicit_lease=True)
                host_kept_out = False
            except RobostarError:
                host_kept_out = True
            await host.client.publish(topic, wire.command_request("cmd/release_control", "{}"))
            await until(lambda: holders()[-1] == "")
        task.cancel()
        assert birth["control/free"].value is True and birth["control/holder"].value == ""
        assert birth["control/until"].datatype == 10  # Double whether free or held
        assert host_kept_out
        entries = [json.loads(line) for line in audit.read_text().splitlines()]
        assert any(e["what"] == "lease take" and e["outcome"].startswith("ok") for e in entries)

    asyncio.run(main())
