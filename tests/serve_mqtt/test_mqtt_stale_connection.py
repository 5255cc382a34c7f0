"""A late failure of an old connection: a publish still out on the connection that went
away fails (times out) after the face has connected again; it must not drop the new, healthy
connection, and a kick left from before a connection must not end the next one."""

from __future__ import annotations

import asyncio
import logging
from typing import Any

import aiomqtt
import pytest

from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.model import Quality, Sample

from .conftest import Broker, until

pytestmark = pytest.mark.timeout(120)


def _server(broker: Broker) -> LineServer:
    return LineServer(
        ServeConfig(
            lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=0.05),),
            faces={"mqtt": {"url": broker.url, "reconnect_max": 0.5}},
        )
    )


def test_a_late_failure_of_the_old_connection_keeps_the_new_one(broker: Broker) -> None:
    async def main() -> None:
        async with _server(broker) as server:
            link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.client is not None)
            new = link.client

            class Old:
                """The connection that went away: its publish fails once the new one is up."""

                async def publish(self, *_: Any, **__: Any) -> None:
                    await asyncio.sleep(0.05)
                    raise aiomqtt.MqttError("Operation timed out")

            link.client = Old()
            sending = asyncio.create_task(link.send("test/x", Sample(1, 0.0, Quality.GOOD)))
            await asyncio.sleep(0)
            link.client = new  # the face connected again meanwhile
            await sending
            assert link.client is new
            assert not link.kicked.is_set()
            assert len(link.buffer) == 0  # the new connection sends the current state anyway

    asyncio.run(main())


def test_a_kick_from_before_a_connection_does_not_end_it(
    broker: Broker, caplog: pytest.LogCaptureFixture
) -> None:
    def connections() -> int:
        return sum("connected to" in r.getMessage() for r in caplog.records)

    async def main() -> None:
        async with _server(broker) as server:
            link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.client is not None)
            broker.stop()
            await until(lambda: link.client is None)
            link.kicked.set()  # a publish failed while the broker was away
            broker.start()
            await until(lambda: connections() >= 2, 20)
            await asyncio.sleep(1.5)
            assert connections() == 2  # not dropped at once and made again

    with caplog.at_level(logging.INFO, "robostar.serve.mqtt"):
        asyncio.run(main())
