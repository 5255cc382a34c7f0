"""The MQTT face's figures (printed, never asserted): ``python -m bench.mqtt_bench``.

Needs Debian's ``mosquitto`` (started here on a free loopback port).

1. Latency: a change in a line's model to a subscriber's receipt, p50/p99: the JSON tree, and
   Sparkplug B DDATA (by alias, decoded).
2. Throughput: 32 simulated controllers moving at once, polled at 20 Hz: messages per second
   reaching a subscriber (after report by exception, deadband and rate cap), JSON and Sparkplug.
3. Replay: 10 minutes of buffered changes (6,000 rows: 10 a second) sent on reconnect.
4. Sparkplug births: NBIRTH and DBIRTH sizes (bytes, metrics) for one simulated controller.
"""

from __future__ import annotations

import asyncio
import json
import sys
import tempfile
import time
from pathlib import Path

import aiomqtt
from tests.serve_mqtt.conftest import MOSQUITTO, Broker

from bench.measure import percentile
from robostar.errors import RobostarError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.mqtt.buffer import StoreAndForward
from robostar.serve.faces.mqtt.sparkplug.session import decode

SPARKPLUG = {"group": "bench", "node": "robostar"}


async def _wait(check, seconds: float = 20.0) -> None:  # type: ignore[no-untyped-def]
    end = time.monotonic() + seconds
    while not check():
        if time.monotonic() > end:
            raise SystemExit("timed out")
        await asyncio.sleep(0.01)


async def latency(broker: Broker, n: int = 300) -> None:
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=1.0),),
        faces={"mqtt": {"url": broker.url, "rate": 1000}},
    )
    got: dict[int, float] = {}
    async with LineServer(config) as server, aiomqtt.Client("127.0.0.1", broker.port) as sub:
        link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
        await _wait(lambda: link.client is not None)
        await sub.subscribe("robostar/cell1/bench", qos=1)

        async def read() -> None:
            async for message in sub.messages:
                value = json.loads(message.payload)["value"]  # type: ignore[arg-type]
                got[value] = time.perf_counter()

        reader = asyncio.create_task(read())
        sent: dict[int, float] = {}
        for k in range(n):
            sent[k] = time.perf_counter()
            server.lines["cell1"].model.set("bench", k)
            await _wait(lambda k=k: k in got)  # type: ignore[misc]
        reader.cancel()
    delays = [got[k] - sent[k] for k in range(n)]
    p50, p99 = percentile(delays, 50) * 1e3, percentile(delays, 99) * 1e3
    print(f"  change -> subscriber            p50 {p50:6.2f} ms   p99 {p99:6.2f} ms ({n} changes)")


async def sparkplug_latency(broker: Broker, n: int = 300) -> None:
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=1.0),),
        faces={"mqtt": {"url": broker.url, "rate": 1000, "sparkplug": SPARKPLUG}},
    )
    got: dict[int, float] = {}
    sizes: dict[str, tuple[int, int]] = {}
    alias: list[int] = []
    async with LineServer(config) as server, aiomqtt.Client("127.0.0.1", broker.port) as sub:
        await sub.subscribe("spBv1.0/bench/#", qos=0)

        async def read() -> None:
            async for message in sub.messages:
                raw = message.payload
                assert isinstance(raw, bytes)
                kind = str(message.topic).split("/")[2]
                payload = decode(raw)
                if kind in ("NBIRTH", "DBIRTH"):
                    sizes[kind] = (len(raw), len(payload.metrics))
                    alias[:] = [m.alias for m in payload.metrics if m.name == "bench"] or alias
                elif kind == "DDATA":
                    for metric in payload.metrics:
                        if alias and metric.alias == alias[0]:
                            got[metric.long_value] = time.perf_counter()

        reader = asyncio.create_task(read())
        model = server.lines["cell1"].model
        model.set("bench", -1)  # a new metric: the device is born again, declaring it
        await _wait(lambda: alias != [])
        sent: dict[int, float] = {}
        for k in range(n):
            sent[k] = time.perf_counter()
            model.set("bench", k)
            await _wait(lambda k=k: k in got)  # type: ignore[misc]
        reader.cancel()
    delays = [got[k] - sent[k] for k in range(n)]
    p50, p99 = percentile(delays, 50) * 1e3, percentile(delays, 99) * 1e3
    print(f"  change -> Sparkplug DDATA       p50 {p50:6.2f} ms   p99 {p99:6.2f} ms ({n} changes)")
    for kind in ("NBIRTH", "DBIRTH"):
        size, metrics = sizes[kind]
        print(f"  {kind} size                     {size:8,} bytes ({metrics} metrics)")


async def throughput(
    broker: Broker, lines: int = 32, seconds: float = 10.0, sparkplug: bool = False
) -> None:
    mqtt = {"url": broker.url, "sparkplug": SPARKPLUG} if sparkplug else {"url": broker.url}
    config = ServeConfig(
        lines=tuple(LineConfig(f"c{i}", "sim://", poll_interval=0.05) for i in range(lines)),
        faces={"mqtt": mqtt},
    )
    count = 0
    async with LineServer(config) as server, aiomqtt.Client("127.0.0.1", broker.port) as sub:
        await sub.subscribe("spBv1.0/bench/DDATA/#" if sparkplug else "robostar/#", qos=0)

        async def shuttle(line) -> None:  # type: ignore[no-untyped-def]
            # Back and forth all along: the positions change at every poll.
            await _wait(lambda: line.up)
            client = line._client  # the bench drives the robots directly
            assert client is not None
            try:
                await client.servo(1, True)
                await client.home(1, wait=True)
                while True:
                    for target in ((100.0, 60.0, 0.0, 0.0), (-100.0, -60.0, 0.0, 0.0)):
                        await client.move(1, target, wait=True)
            except RobostarError as exc:  # a figure without moving robots would mislead
                print(f"  (a robot stopped moving: {exc})", file=sys.stderr)

        movers = [asyncio.create_task(shuttle(line)) for line in server.lines.values()]

        async def read() -> None:
            nonlocal count
            async for _ in sub.messages:
                count += 1

        reader = asyncio.create_task(read())
        await asyncio.sleep(1.0)
        start, count = time.perf_counter(), 0
        await asyncio.sleep(seconds)
        rate = count / (time.perf_counter() - start)
        reader.cancel()
        for mover in movers:
            mover.cancel()
    what = "Sparkplug DDATA" if sparkplug else "JSON tree"
    print(f"  {lines} moving controllers ({what}) {rate:8.0f} messages/s at the subscriber")


async def replay(broker: Broker, rows: int = 6000) -> None:
    with tempfile.TemporaryDirectory() as folder:
        buffer = StoreAndForward(Path(folder) / "b.sqlite", max_rows=rows * 2)
        payload = json.dumps({"value": 1.0, "ts": 0.0, "quality": "good"}).encode()
        for _ in range(rows):
            buffer.put("robostar/cell1/ch1/speed", payload, False)
        async with aiomqtt.Client("127.0.0.1", broker.port) as client:
            start = time.perf_counter()
            while batch := buffer.peek(500):
                for row in batch:
                    await client.publish(row.topic, row.payload, qos=1)
                buffer.remove(batch[-1].id)
            took = time.perf_counter() - start
        buffer.close()
    print(f"  replay of {rows} buffered changes  {took:8.2f} s ({rows / took:,.0f} rows/s, QoS 1)")


def main() -> int:
    if MOSQUITTO is None:
        print("mosquitto is not installed (apt-get install mosquitto)", file=sys.stderr)
        return 1
    with tempfile.TemporaryDirectory() as folder:
        broker = Broker(Path(folder))
        broker.start()
        try:
            print("MQTT face (mosquitto on loopback, 2 shared cores):")
            asyncio.run(latency(broker))
            asyncio.run(sparkplug_latency(broker))
            asyncio.run(throughput(broker))
            asyncio.run(throughput(broker, sparkplug=True))
            asyncio.run(replay(broker))
        finally:
            broker.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
