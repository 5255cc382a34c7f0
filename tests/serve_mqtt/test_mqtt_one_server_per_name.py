"""A plant has many line servers on one broker: a second server whose prefix, or whose Sparkplug
node id, is already online there is refused at start (their values and commands would mix); a
different prefix, or the same one after the first stopped, starts."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from robostar.errors import UsageError
from robostar.serve import LineConfig, LineServer, ServeConfig

from .conftest import Broker, until

pytestmark = pytest.mark.timeout(120)


def _server(broker: Broker, client_id: str, **mqtt: Any) -> LineServer:
    return LineServer(
        ServeConfig(
            lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=0.05),),
            faces={"mqtt": {"url": broker.url, "client_id": client_id, **mqtt}},
        )
    )


def test_a_second_server_under_an_online_prefix_is_refused(broker: Broker) -> None:
    async def main() -> None:
        prefix = "acme/plant1/body/cell3"  # an ISA-95 path: enterprise/site/area/cell
        async with _server(broker, "first", prefix=prefix) as first:
            presence = lambda: first.faces["mqtt"].presence is not None  # type: ignore[attr-defined]  # noqa: E731
            await until(presence)
            with pytest.raises(UsageError, match="online under the prefix"):
                await _server(broker, "second", prefix=prefix).start()
            async with _server(broker, "third", prefix="acme/plant1/body/cell4"):
                pass  # another cell's prefix: fine
        async with _server(broker, "second", prefix=prefix):
            pass  # the first stopped (its birth says false): fine

    asyncio.run(main())


def test_a_second_server_with_an_online_sparkplug_node_is_refused(broker: Broker) -> None:
    node = {"group": "plant1", "node": "cell3"}

    async def main() -> None:
        async with _server(broker, "first", prefix="a", sparkplug=node) as first:
            spark: Any = first.faces["mqtt"].sparkplug  # type: ignore[attr-defined]
            await until(lambda: spark.client is not None)
            with pytest.raises(UsageError, match="Sparkplug node plant1/cell3 is online"):
                await _server(broker, "second", prefix="b", sparkplug=node).start()

    asyncio.run(main())
