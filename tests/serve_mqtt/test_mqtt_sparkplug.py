"""Sparkplug B on the MQTT face against a real Mosquitto, every payload read by an independent
decoder (tests/serve_mqtt/sparkplug_wire.py): the births declare every metric (name, alias,
datatype, value, time, units and quality), data goes by alias and by exception, seq counts
0-255 across the node's messages in order, the NDEATH carries the NBIRTH's bdSeq, a rebirth
request is honoured with the same aliases, a line that goes down is a DDEATH, and DCMD commands
run only when enabled, through the allowlist and the audit log."""

from __future__ import annotations

import asyncio
import json
import socket
from pathlib import Path
from typing import Any

import aiomqtt
import pytest

from robostar.errors import UsageError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.mqtt import settings_from
from robostar.sim.controller import VirtualController
from robostar.sim.listeners import SimServer

from . import sparkplug_wire as wire
from .conftest import Broker, until

pytestmark = pytest.mark.timeout(120)

GROUP, NODE = "plant", "robostar1"
BOOLEAN, INT64, DOUBLE, STRING = 11, 4, 10, 12


class Host:
    """A host application's view: every message under spBv1.0/, in order, decoded."""

    def __init__(self) -> None:
        self.messages: list[tuple[str, wire.Payload]] = []
        self.client: aiomqtt.Client | None = None

    async def run(self, broker: Broker, ready: asyncio.Event) -> None:
        async with aiomqtt.Client("127.0.0.1", broker.port) as client:
            self.client = client
            await client.subscribe("spBv1.0/#", qos=1)
            ready.set()
            async for message in client.messages:
                raw = message.payload
                assert isinstance(raw, bytes)
                if str(message.topic).startswith("spBv1.0/STATE/"):
                    continue  # a host application's JSON, not a node's payload
                self.messages.append((str(message.topic), wire.read(raw)))

    def of(self, kind: str, device: str | None = None) -> list[wire.Payload]:
        topic = f"spBv1.0/{GROUP}/{kind}/{NODE}" + (f"/{device}" if device else "")
        return [p for t, p in self.messages if t == topic]

    def session_seqs(self) -> list[int]:
        """The seq of every N/D message but NDEATH, in arrival order."""
        return [p.seq for t, p in self.messages if "/NDEATH/" not in t and p.seq is not None]


async def _host(broker: Broker) -> tuple[Host, asyncio.Task[None]]:
    host, ready = Host(), asyncio.Event()
    task = asyncio.create_task(host.run(broker, ready))
    await asyncio.wait_for(ready.wait(), 10)
    return host, task


def _config(broker: Broker, url: str = "sim://?speedup=20", **mqtt: Any) -> ServeConfig:
    return ServeConfig(
        lines=(LineConfig("cell1", url, poll_interval=0.05),),
        faces={"mqtt": {"url": broker.url, "sparkplug": {"group": GROUP, "node": NODE}, **mqtt}},
    )


def _by_name(birth: wire.Payload) -> dict[str, wire.Metric]:
    return {m.name: m for m in birth.metrics if m.name is not None}


def test_births_declare_every_metric_and_data_follows_by_alias(broker: Broker) -> None:
    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(_config(broker, rate=1000)) as server:
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            line = server.lines["cell1"]
            # A metric the birth did not declare: the device is born again, declaring it;
            # its next change is a DDATA.
            line.model.set("test/counter", 1)
            await until(lambda: "test/counter" in _by_name(host.of("DBIRTH", "cell1")[-1]))
            before = len(host.of("DDATA", "cell1"))
            line.model.set("test/counter", 2)
            await until(lambda: len(host.of("DDATA", "cell1")) > before)
        await until(lambda: host.of("NDEATH") != [])  # a clean stop says it, as the will would
        task.cancel()
        nbirth = host.of("NBIRTH")[0]
        assert nbirth.seq == 0
        node_metrics = _by_name(nbirth)
        assert node_metrics["bdSeq"].datatype == INT64
        assert node_metrics["Node Control/Rebirth"].value is False
        dbirth = host.of("DBIRTH", "cell1")[-1]
        metrics = _by_name(dbirth)
        for metric in dbirth.metrics:  # every metric is declared in full
            assert metric.name and metric.alias and metric.timestamp and metric.datatype
            assert metric.properties["Quality"] == 192
        assert metrics["ch1/status/servo_on"].datatype == BOOLEAN
        assert metrics["ch1/position/x"].datatype == DOUBLE
        assert metrics["ch1/position/x"].properties["engUnit"] == "mm"
        assert metrics["ch1/position/r"].properties["engUnit"] == "deg"
        assert metrics["ch1/speed"].datatype == INT64
        assert metrics["io/in/0/15"].datatype == BOOLEAN
        assert not any(name.startswith("ch3/") for name in metrics)  # the sim has 2 channels
        assert len({m.alias for m in dbirth.metrics}) == len(dbirth.metrics)
        counter = metrics["test/counter"]
        values = []
        for data in host.of("DDATA", "cell1"):
            for metric in data.metrics:
                assert metric.name is None and metric.alias is not None  # by alias alone
                if metric.alias == counter.alias:
                    values.append(metric.value)
        assert values[-1] == 2
        seqs = host.session_seqs()
        assert seqs == [k % 256 for k in range(len(seqs))]
        # The NDEATH carries the NBIRTH's bdSeq.
        deaths = [_by_name(p)["bdSeq"].value for p in host.of("NDEATH")]
        assert deaths == [node_metrics["bdSeq"].value]

    asyncio.run(main())


def test_rebirth_on_request_keeps_the_aliases(broker: Broker) -> None:
    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(_config(broker)):
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            assert host.client is not None
            await host.client.publish(f"spBv1.0/{GROUP}/NCMD/{NODE}", wire.rebirth_request(), qos=1)
            await until(lambda: len(host.of("DBIRTH", "cell1")) >= 2)
        task.cancel()
        first, second = host.of("NBIRTH")[:2]
        assert second.seq == 0
        assert _by_name(first)["bdSeq"].value == _by_name(second)["bdSeq"].value
        births = host.of("DBIRTH", "cell1")
        aliases = [{m.name: m.alias for m in birth.metrics} for birth in births[:2]]
        assert aliases[0] == aliases[1]

    asyncio.run(main())


def test_the_will_is_the_ndeath_of_the_connection(broker: Broker) -> None:
    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(_config(broker, reconnect_max=0.5)) as server:
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            node = server.faces["mqtt"].sparkplug  # type: ignore[attr-defined]
            # The connection dies without a word (as a power cut would): the broker says the
            # will, and the node comes back with a new session, bdSeq one more.
            node.client._client.socket().shutdown(socket.SHUT_RDWR)
            await until(lambda: host.of("NDEATH") != [], 30)
            await until(lambda: len(host.of("NBIRTH")) >= 2, 30)
        task.cancel()
        births = [_by_name(p)["bdSeq"].value for p in host.of("NBIRTH")]
        death = _by_name(host.of("NDEATH")[0])["bdSeq"].value
        assert death == births[0] and births[1] == (births[0] + 1) % 256

    asyncio.run(main())


def test_a_line_that_goes_down_is_a_ddeath(broker: Broker) -> None:
    sim = SimServer(VirtualController()).start()

    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(_config(broker, url=sim.url)) as server:
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            sim.close()
            await until(lambda: not server.lines["cell1"].up, 30)
            await until(lambda: host.of("DDEATH", "cell1") != [], 30)
        task.cancel()
        kinds = [t.split("/")[2] for t, _ in host.messages]
        assert kinds.index("DDEATH") > kinds.index("DBIRTH")
        seqs = host.session_seqs()
        assert seqs == [k % 256 for k in range(len(seqs))]

    try:
        asyncio.run(main())
    finally:
        sim.close()


def test_dcmd_runs_an_allowed_command_and_refuses_the_rest(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"
    config = _config(broker, commands={"enabled": True, "allow": ["speed"]})
    config = ServeConfig(lines=config.lines, faces=config.faces, audit_path=str(audit))

    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(config) as server:
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            assert host.client is not None
            topic = f"spBv1.0/{GROUP}/DCMD/{NODE}/cell1"
            await host.client.publish(
                topic, wire.command_request("cmd/speed", '{"channel": 1, "value": 45}'), qos=1
            )
            await host.client.publish(
                topic, wire.command_request("cmd/servo", '{"channel": 1, "on": true}'), qos=1
            )
            birth = _by_name(host.of("DBIRTH", "cell1")[0])
            result_alias = birth["cmd/speed/result"].alias

            def results() -> list[Any]:
                return [
                    json.loads(m.value)
                    for p in host.of("DDATA", "cell1")
                    for m in p.metrics
                    if m.alias == result_alias
                ]

            await until(lambda: results() != [])
            await until(lambda: "cmd/servo" in audit.read_text())
            speed = server.lines["cell1"].model.get("ch1/speed")
        task.cancel()
        assert results()[0]["ok"] is True
        assert "cmd/servo" not in birth  # not enabled: not declared, not run
        entries = [json.loads(line) for line in audit.read_text().splitlines()]
        assert any("SetSpeed" in e["what"] and e["outcome"] == "ok" for e in entries)
        assert any(e["what"] == "cmd/servo" and "not enabled" in e["outcome"] for e in entries)
        assert speed is not None

    asyncio.run(main())


@pytest.mark.parametrize(
    ("sparkplug", "error"),
    [
        ({"group": "a/b", "node": "n"}, "sparkplug.group"),
        ({"group": "g"}, "sparkplug.node"),
        ({"group": "g", "node": "n", "colour": 1}, "sparkplug.colour"),
        ("yes", "mqtt.sparkplug"),
    ],
)
def test_bad_sparkplug_settings_are_refused(sparkplug: Any, error: str) -> None:
    with pytest.raises(UsageError, match=error):
        settings_from({"url": "mqtt://h", "sparkplug": sparkplug})


def test_the_node_is_born_only_while_the_primary_host_is_online(broker: Broker) -> None:
    config = _config(broker, reconnect_max=0.5)
    faces = {"mqtt": {**config.faces["mqtt"], "sparkplug": {"group": GROUP, "node": NODE,
                                                            "primary_host": "scada"}}}  # fmt: skip
    config = ServeConfig(lines=config.lines, faces=faces)

    async def state(client: aiomqtt.Client, online: bool) -> None:
        body = json.dumps({"online": online, "timestamp": 1}).encode()
        await client.publish("spBv1.0/STATE/scada", body, qos=1, retain=True)

    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(config) as server:
            await server.lines["cell1"].wait_polled()
            await asyncio.sleep(1.0)
            assert host.of("NBIRTH") == []  # no primary host online yet
            assert host.client is not None
            await state(host.client, True)
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            await state(host.client, False)  # the host went away: the session ends
            await until(lambda: host.of("NDEATH") != [])
            await state(host.client, True)  # back: born again
            await until(lambda: len(host.of("NBIRTH")) >= 2, 30)
        task.cancel()

    asyncio.run(main())


def test_a_dcmd_stop_never_waits_behind_another_command(broker: Broker) -> None:
    config = _config(broker, commands={"enabled": True, "allow": ["speed", "stop_job"]})

    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(config) as server:
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            line = server.lines["cell1"]
            real, release = line.execute, asyncio.Event()

            async def held(command: Any, **kwargs: Any) -> Any:
                if type(command).__name__ == "SetSpeed":
                    await release.wait()  # a command that takes its time
                return await real(command, **kwargs)

            line.execute = held  # type: ignore[method-assign]
            assert host.client is not None
            topic = f"spBv1.0/{GROUP}/DCMD/{NODE}/cell1"
            speed = wire.command_request("cmd/speed", '{"channel": 1, "value": 45}')
            stop = wire.command_request("cmd/stop_job", '{"channel": 1}')
            await host.client.publish(topic, speed, qos=1)
            await host.client.publish(topic, stop, qos=1)
            birth = _by_name(host.of("DBIRTH", "cell1")[0])
            stop_result = birth["cmd/stop_job/result"].alias
            await until(
                lambda: any(
                    m.alias == stop_result for p in host.of("DDATA", "cell1") for m in p.metrics
                )
            )
            assert not release.is_set()  # the stop ran while the speed still waited
            release.set()
        task.cancel()

    asyncio.run(main())


def test_changes_while_the_broker_is_away_come_as_historical_after_the_birth(
    broker: Broker,
) -> None:
    async def main() -> None:
        async with LineServer(_config(broker, rate=1000, reconnect_max=0.5)) as server:
            node: Any = server.faces["mqtt"].sparkplug  # type: ignore[attr-defined]
            line = server.lines["cell1"]
            line.model.set("test/counter", 0)  # declared by a birth before the broker goes
            await until(lambda: node.client is not None and "cell1" in node.session.born)
            await until(lambda: node.session.declared("cell1", _counter(0)))
            broker.stop()
            await until(lambda: node.client is None)
            for k in range(1, 6):
                line.model.set("test/counter", k)
                await asyncio.sleep(0.1)
            await until(lambda: len(node.devices["cell1"].history) >= 5)
            broker.start()
            host, task = await _host(broker)
            await until(lambda: host.of("DBIRTH", "cell1") != [], 30)
            await until(lambda: any(
                m.is_historical for p in host.of("DDATA", "cell1") for m in p.metrics
            ))  # fmt: skip
            task.cancel()
        birth = _by_name(host.of("DBIRTH", "cell1")[0])
        assert birth["test/counter"].value == 5  # the birth: the current state
        alias = birth["test/counter"].alias
        history = [m for p in host.of("DDATA", "cell1") for m in p.metrics if m.alias == alias]
        assert all(m.is_historical for m in history)
        assert [m.value for m in history] == [1, 2, 3, 4, 5]  # in order, each as it was
        times = [m.timestamp for m in history]
        assert times == sorted(times)

    asyncio.run(main())


def _counter(value: int) -> Any:
    from robostar.serve.faces.mqtt.sparkplug.session import Metric

    return Metric("test/counter", value, 0.0)
