"""A stop always ends the value pumps, even when a publish swallowed the cancellation: on
Python 3.11 asyncio.wait_for (inside aiomqtt's publish) can return normally although its task
was cancelled, and the pump must then stop at its next wait instead of waiting forever."""

from __future__ import annotations

import asyncio
from typing import Any

import aiomqtt
import pytest

from robostar.serve import LineConfig, LineServer, ServeConfig

from .conftest import Broker, until

pytestmark = pytest.mark.timeout(60)


class SwallowingClient:
    """A connection whose first publish, cancelled while it waits, returns as if it had gone
    out; later ones fail (the stop's offline)."""

    def __init__(self) -> None:
        self.waiting = asyncio.Event()

    async def publish(self, *_: Any, **__: Any) -> None:
        if self.waiting.is_set():
            raise aiomqtt.MqttError("gone")
        self.waiting.set()
        try:
            await asyncio.sleep(3600)
        except asyncio.CancelledError:
            return  # what wait_for does when the cancellation races with its result


def test_a_stop_ends_a_pump_whose_publish_swallowed_the_cancellation(broker: Broker) -> None:
    async def main() -> None:
        server = LineServer(
            ServeConfig(
                # Polled once, then quiet: no change wakes the pump once it is cancelled.
                lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=120.0),),
                faces={"mqtt": {"url": broker.url}},
            )
        )
        await server.start()
        face: Any = server.faces["mqtt"]
        link = face.links["cell1"]
        await until(lambda: link.client is not None)
        await until(lambda: server.lines["cell1"].health.last_poll is not None)
        await asyncio.sleep(0.5)  # the first poll's values out
        swallowing = SwallowingClient()
        link.client = swallowing
        server.lines["cell1"].model.set("test/value", 1)
        await swallowing.waiting.wait()
        await server.stop()  # without the fix the pump waits for a change that never comes
        assert not face.tasks

    asyncio.run(main())
