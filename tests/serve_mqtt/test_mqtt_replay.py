"""Store and forward after a reconnect: live values are never stuck in the buffer, and the
replay ends while the robot keeps moving, behind a broker with latency."""

from __future__ import annotations

import asyncio
import json
import time
from typing import Any

import pytest

from robostar.serve import LineConfig, LineServer, ServeConfig

from .conftest import Broker, LatencyProxy, until

pytestmark = pytest.mark.timeout(120)


def _server(url: str, **mqtt: Any) -> LineServer:
    return LineServer(
        ServeConfig(
            lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=0.05),),
            faces={"mqtt": {"url": url, **mqtt}},
        )
    )


def test_a_row_left_in_the_buffer_does_not_send_live_values_to_it(broker: Broker) -> None:
    """A row that reached the buffer after a replay (a change landing while the replay's last
    publish was out) must not make every later value go to the buffer while connected."""

    async def main() -> None:
        async with _server(broker.url, rate=1000) as server:
            line = server.lines["cell1"]
            link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.client is not None and not link.replaying)
            link.buffer.put("robostar/cell1/test/old", b'{"value": 0, "historical": true}', False)
            published = link.published
            for k in range(1, 4):
                line.model.set("test/live", k)
                await asyncio.sleep(0.05)
            await until(lambda: link.published >= published + 3, 5)
            assert not any(r.topic == "robostar/cell1/test/live" for r in link.buffer.peek(100))

    asyncio.run(main())


def test_the_replay_ends_while_values_keep_changing_behind_latency(broker: Broker) -> None:
    """1,000 buffered rows, a broker 20 ms away, a model changing every 10 ms: the replay sends
    only what waited when it began (live changes wait in the reporter, the latest per topic),
    pipelined, so it ends in about a second instead of never."""

    async def main() -> None:
        proxy = LatencyProxy(broker.port, 0.02)
        await proxy.start()
        try:
            async with _server(proxy.url, reconnect_max=0.5) as server:
                line = server.lines["cell1"]
                link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
                await until(lambda: link.client is not None and not link.replaying)
                broker.stop()
                await until(lambda: link.client is None)
                for k in range(1000):
                    body = {"value": k, "ts": 0, "quality": "good", "historical": True}
                    link.buffer.put("robostar/cell1/test/old", json.dumps(body).encode(), False)

                async def move() -> None:
                    k = 0
                    while True:
                        k += 1
                        line.model.set("test/moving", k)
                        await asyncio.sleep(0.01)

                mover = asyncio.create_task(move())
                try:
                    broker.start()
                    await until(lambda: link.replaying, 20)
                    began = time.monotonic()
                    most = len(link.buffer)
                    while link.replaying and time.monotonic() - began < 20:
                        most = max(most, len(link.buffer))
                        await asyncio.sleep(0.01)
                    took = time.monotonic() - began
                    assert not link.replaying, f"still replaying after {took:.1f} s"
                    assert took < 8, took
                    assert most <= 1000  # nothing live was added to the buffer meanwhile
                    # Then live values go out again.
                    published = link.published
                    await until(lambda: link.published > published + 5, 15)
                    assert len(link.buffer) == 0
                finally:
                    mover.cancel()
        finally:
            await proxy.stop()

    asyncio.run(main())
