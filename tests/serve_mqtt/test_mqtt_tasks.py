"""The face's tasks survive their failures: an SQLite error in the store-and-forward buffer
(a full disk) loses that change, counted, and the pump keeps going; a task that ends with an
error anyway is logged and started again."""

from __future__ import annotations

import asyncio
import logging
import sqlite3
from typing import Any

import pytest

from robostar.serve import LineConfig, LineServer, ServeConfig

from .conftest import Broker, until

pytestmark = pytest.mark.timeout(120)


def _server(broker: Broker, **mqtt: Any) -> LineServer:
    return LineServer(
        ServeConfig(
            lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=0.05),),
            faces={"mqtt": {"url": broker.url, "reconnect_max": 0.5, **mqtt}},
        )
    )


def _pumps(server: LineServer) -> list[asyncio.Task[Any]]:
    tasks = server.faces["mqtt"].tasks  # type: ignore[attr-defined]
    return [t for t in tasks if t.get_coro().__qualname__ == "BrokerLink.pump"]


def test_a_full_disk_under_the_buffer_does_not_end_the_pump(
    broker: Broker, caplog: pytest.LogCaptureFixture
) -> None:
    async def main() -> None:
        async with _server(broker) as server:
            line = server.lines["cell1"]
            link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.client is not None)
            broker.stop()
            await until(lambda: link.client is None)

            def full(*_: Any) -> None:
                raise sqlite3.OperationalError("database or disk is full")

            link.buffer.put = full
            for k in range(5):
                line.model.set("test/value", k)
                await asyncio.sleep(0.05)
            await until(lambda: link.buffer_lost > 0, 5)
            assert [t.done() for t in _pumps(server)] == [False]
            del link.buffer.put  # the disk has room again
            broker.start()
            await until(lambda: link.client is not None, 20)
            published = link.published
            line.model.set("test/value", 99)
            await until(lambda: link.published > published, 5)

    with caplog.at_level(logging.WARNING, "robostar.serve.mqtt"):
        asyncio.run(main())
    assert any("not buffered" in r.getMessage() for r in caplog.records)


def test_a_task_that_fails_is_logged_and_started_again(
    broker: Broker, caplog: pytest.LogCaptureFixture
) -> None:
    async def main() -> None:
        async with _server(broker) as server:
            line = server.lines["cell1"]
            link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
            await until(lambda: link.client is not None)
            real = link.reporter.due
            calls = {"n": 0}

            def due(now: float) -> Any:
                calls["n"] += 1
                if calls["n"] == 1:
                    raise RuntimeError("a bug in the pump")
                return real(now)

            link.reporter.due = due
            line.model.set("test/value", 1)
            await until(lambda: calls["n"] >= 1, 5)
            published = link.published
            line.model.set("test/value", 2)
            await until(lambda: link.published > published, 10)
            assert [t.done() for t in _pumps(server)] == [False]

    with caplog.at_level(logging.ERROR, "robostar.serve.mqtt"):
        asyncio.run(main())
    assert any("a bug in the pump" in r.getMessage() or r.exc_info for r in caplog.records)
