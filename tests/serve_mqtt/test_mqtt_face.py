"""The MQTT face against a real Mosquitto: retained state, last wills, store and forward,
report by exception, commands."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import subprocess
import sys
import time
from typing import Any

import aiomqtt
import pytest
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties

from robostar.errors import UsageError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.mqtt import settings_from
from robostar.serve.faces.mqtt.buffer import StoreAndForward
from robostar.serve.faces.mqtt.reporter import Reporter
from robostar.serve.model import Quality, Sample
from robostar.types import ArmForm, Position, PositionKind

from .conftest import Broker, until

pytestmark = pytest.mark.timeout(180)


def _server(broker: Broker, **mqtt: Any) -> LineServer:
    return LineServer(
        ServeConfig(
            lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=0.05),),
            faces={"mqtt": {"url": broker.url, **mqtt}},
        )
    )


class Collector:
    """A subscriber of robostar/# keeping every message."""

    def __init__(self) -> None:
        self.messages: list[tuple[str, Any, bool]] = []

    def values(self, topic: str) -> list[Any]:
        return [payload for t, payload, _ in self.messages if t == topic]

    async def run(self, broker: Broker, ready: asyncio.Event, pattern: str = "robostar/#") -> None:
        async with aiomqtt.Client("127.0.0.1", broker.port) as client:
            await client.subscribe(pattern, qos=1)
            ready.set()
            async for message in client.messages:
                raw = message.payload
                text = raw.decode() if isinstance(raw, bytes) else str(raw)
                try:
                    payload: Any = json.loads(text)
                except ValueError:
                    payload = text
                self.messages.append((str(message.topic), payload, bool(message.retain)))


async def _subscribe(broker: Broker) -> tuple[Collector, asyncio.Task[None]]:
    collector, ready = Collector(), asyncio.Event()
    task = asyncio.create_task(collector.run(broker, ready))
    await asyncio.wait_for(ready.wait(), 10)
    return collector, task


def test_a_late_subscriber_gets_the_retained_state(broker: Broker) -> None:
    async def main() -> None:
        async with _server(broker) as server:
            face = server.faces["mqtt"]
            link = face.links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.published > 5)
            late, task = await _subscribe(broker)  # connects after the values went out
            await until(lambda: late.values("robostar/cell1/ch1/status") != [])
            task.cancel()
        assert late.values("robostar/cell1/online") == [True]
        assert late.values("robostar/_server/online") == [True]
        status = late.values("robostar/cell1/ch1/status")[0]
        assert status["quality"] == "good" and status["value"]["ready"] is True
        assert abs(status["ts"] - time.time()) < 30
        retained = {t for t, _, r in late.messages if r}
        assert {
            "robostar/cell1/online",
            "robostar/cell1/ch1/status",
            "robostar/cell1/info",
        } <= retained

    asyncio.run(main())


def test_a_clean_stop_says_offline(broker: Broker) -> None:
    async def main() -> Collector:
        sub, task = await _subscribe(broker)
        async with _server(broker) as server:
            link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.client is not None)
        await until(lambda: sub.values("robostar/cell1/online")[-1:] == [False])
        task.cancel()
        return sub

    sub = asyncio.run(main())
    assert sub.values("robostar/cell1/online")[0] is True


def test_the_last_will_on_kill_9(broker: Broker) -> None:
    command = [
        sys.executable, "-m", "robostar", "serve", "--line", "cell1=sim://",
        "--mqtt", broker.url,
    ]  # fmt: skip
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    async def main() -> Collector:
        sub, task = await _subscribe(broker)
        try:
            await until(lambda: sub.values("robostar/cell1/online")[-1:] == [True], 30)
            await until(lambda: sub.values("robostar/_server/online")[-1:] == [True], 30)
            os.kill(process.pid, signal.SIGKILL)
            await until(lambda: sub.values("robostar/cell1/online")[-1:] == [False], 30)
            await until(lambda: sub.values("robostar/_server/online")[-1:] == [False], 30)
        finally:
            task.cancel()
        return sub

    try:
        asyncio.run(main())
    finally:
        process.kill()
        process.wait(10)


def test_broker_restart_replays_the_buffered_changes_in_order(broker: Broker) -> None:
    async def main() -> None:
        async with _server(broker, rate=1000, reconnect_max=0.5) as server:
            line = server.lines["cell1"]
            link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.client is not None)
            broker.stop()
            await until(lambda: link.client is None)
            # Changes while the broker is away: each goes to the buffer, in order. (A key the
            # poller never writes: it would read the controller's own value over the last.)
            for k in range(30):
                line.model.set("test/counter", 100 + k)
                await asyncio.sleep(0.05)
            topic = "robostar/cell1/test/counter"
            buffered = lambda: [  # noqa: E731
                json.loads(r.payload)["value"] for r in link.buffer.peek(10_000) if r.topic == topic
            ]
            await until(lambda: buffered()[-1:] == [129])
            waiting = buffered()
            broker.start()
            sub, task = await _subscribe(broker)
            await until(lambda: len(link.buffer) == 0, 30)
            await until(lambda: 129 in [m["value"] for m in sub.values(topic)])
            task.cancel()
        speeds = sub.values(topic)
        historical = [m for m in speeds if m.get("historical")]
        # Everything the face took while the broker was away comes back, in order, marked
        # historical (the model coalesces a key's changes faster than the face reads them,
        # so under load some of the 30 may never have been taken; never reordered).
        assert [m["value"] for m in historical] == waiting
        assert waiting == sorted(waiting) and waiting[-1] == 129 and len(waiting) >= 2
        times = [m["ts"] for m in historical]
        assert times == sorted(times)
        assert link.buffer.dropped == 0

    asyncio.run(main())


def test_commands_are_refused_unless_enabled_and_allowed(broker: Broker) -> None:
    async def ask(
        server_options: dict[str, Any], name: str, body: dict[str, Any], wait: float = 10.0
    ) -> Any:
        async with _server(broker, **server_options) as server:
            link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.client is not None)
            async with aiomqtt.Client(
                "127.0.0.1", broker.port, protocol=aiomqtt.ProtocolVersion.V5
            ) as client:
                await client.subscribe("answers/#", qos=1)
                props = Properties(PacketTypes.PUBLISH)  # type: ignore[no-untyped-call]
                props.ResponseTopic = "answers/me"
                props.CorrelationData = b"corr-7"
                await client.publish(
                    f"robostar/cell1/cmd/{name}",
                    json.dumps(body).encode(),
                    qos=1,
                    properties=props,
                )
                try:
                    async with asyncio.timeout(wait):
                        async for message in client.messages:
                            corr = getattr(message.properties, "CorrelationData", None)
                            raw = message.payload
                            text = raw.decode() if isinstance(raw, bytes) else str(raw)
                            return json.loads(text), corr, line_speed(server)
                except TimeoutError:
                    return None, None, line_speed(server)
        return None, None, None

    def line_speed(server: LineServer) -> Any:
        sim = server.lines["cell1"]
        return sim.model.get("ch1/speed")

    async def main() -> None:
        # Off by default: the face does not even listen, and nothing changes.
        off, _, speed = await ask({}, "speed", {"channel": 1, "value": 40, "id": 1}, wait=1.5)
        assert off is None and (speed is None or speed.value != 40)
        allow = {"commands": {"enabled": True, "allow": ["output"]}}
        no, _, _ = await ask(allow, "speed", {"channel": 1, "value": 40})
        assert no["ok"] is False and "not enabled" in no["error"]
        allow = {"commands": {"enabled": True, "allow": ["speed"]}}
        bad, _, _ = await ask(allow, "speed", {"channel": 1, "value": 5000, "id": "x"})
        assert bad["ok"] is False and bad["id"] == "x" and "speed" in bad["error"]
        good, corr, _ = await ask(allow, "speed", {"channel": 1, "value": 40, "id": "y"})
        assert good == {"ok": True, "result": None, "id": "y"} and corr == b"corr-7"

    asyncio.run(main())


def test_an_accepted_command_reaches_the_controller_and_the_audit(
    broker: Broker, tmp_path: Any
) -> None:
    async def main() -> None:
        audit = tmp_path / "audit.jsonl"
        config = ServeConfig(
            lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=0.05),),
            faces={"mqtt": {"url": broker.url, "commands": {"enabled": True, "allow": ["speed"]}}},
            audit_path=str(audit),
        )
        from robostar.commands.control import ReadSpeed

        async with LineServer(config) as server:
            link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.client is not None)
            async with aiomqtt.Client("127.0.0.1", broker.port) as client:
                await client.subscribe("robostar/cell1/cmd/speed/result", qos=1)
                await client.publish(
                    "robostar/cell1/cmd/speed", b'{"channel": 1, "value": 77, "id": 5}', qos=1
                )
                async with asyncio.timeout(10):
                    async for message in client.messages:
                        assert json.loads(message.payload)["ok"] is True  # type: ignore[arg-type]
                        break
            speed = await server.lines["cell1"].read(ReadSpeed(1), max_age=0)
            assert speed == 77
        entries = [json.loads(line) for line in audit.read_text().splitlines()]
        assert any(
            e["face"] == "mqtt" and "SetSpeed" in e["what"] and e["outcome"] == "ok"
            for e in entries
        )

    asyncio.run(main())


# -- pure parts -----------------------------------------------------------------------------------
def _position(x: float) -> Position:
    return Position(PositionKind.XY, (x, 0.0), ArmForm.NONE)


def test_report_by_exception_with_a_deadband_on_positions() -> None:
    reporter = Reporter(deadband=0.5, max_rate=1000)
    sent = []
    for x in (0.0, 0.2, 0.4, 0.6, 0.7, 2.0):
        reporter.offer("ch1/position", Sample(_position(x), 0.0))
        sent += [s.value.axes[0] for _, s in reporter.due(1.0)]
    assert sent == [0.0, 0.6, 2.0]
    assert reporter.suppressed == 3
    # the same value with another quality always goes out
    reporter.offer("ch1/position", Sample(_position(2.0), 0.0, Quality.LINE_DOWN))
    assert len(reporter.due(1.0)) == 1


def test_the_rate_cap_holds_the_latest_per_topic() -> None:
    reporter = Reporter(deadband=0.0, max_rate=2)
    for k in range(10):
        reporter.offer(f"io/in/{k % 3}", Sample(k, 0.0))
    first = reporter.due(0.0)
    assert len(first) == 2  # a burst of one second's worth
    assert reporter.next_due(0.0) == pytest.approx(0.5)
    later = reporter.due(10.0)
    values = dict((key, s.value) for key, s in first + later)
    assert values == {"io/in/0": 9, "io/in/1": 7, "io/in/2": 8}  # the latest of each arrives


def test_the_buffer_is_bounded_ordered_and_counts_what_it_drops() -> None:
    buffer = StoreAndForward(max_rows=5)
    for k in range(8):
        buffer.put("t", str(k).encode(), False)
    assert len(buffer) == 5 and buffer.dropped == 3
    rows = buffer.peek(10)
    assert [r.payload for r in rows] == [b"3", b"4", b"5", b"6", b"7"]
    buffer.remove(rows[1].id)
    assert [r.payload for r in buffer.peek(10)] == [b"5", b"6", b"7"]


@pytest.mark.parametrize(
    ("options", "error"),
    [
        ({}, "mqtt.url"),
        ({"url": "http://x"}, "mqtt.url"),
        ({"url": "mqtt://h", "qos": 3}, "mqtt.qos"),
        ({"url": "mqtt://h", "prefix": "a/+"}, "mqtt.prefix"),
        ({"url": "mqtt://h", "rate": 0}, "mqtt.rate"),
        ({"url": "mqtt://h", "commands": {"enabled": True, "allow": ["fly"]}}, "allow"),
        ({"url": "mqtt://h", "color": "red"}, "mqtt.color"),
        ({"url": "mqtt://h", "password_env": "ROBOSTAR_NO_SUCH_VAR"}, "password_env"),
    ],
)
def test_bad_settings_are_refused_naming_the_key(options: dict[str, Any], error: str) -> None:
    with pytest.raises(UsageError, match=error):
        settings_from(options)


def test_commands_are_off_by_default_and_credentials_never_shown() -> None:
    settings = settings_from({"url": "mqtts://user:secret@broker.example:8883"})
    assert settings.commands == frozenset() and settings.tls and settings.port == 8883
    assert "secret" not in repr(settings)
