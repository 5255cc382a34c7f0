"""A poll that fails as the line drops leaves "online: false" good: the line's own values are
set as it opens and drops, not vouched for by the poller (OPC UA showed Online as
UncertainLastUsableValue while the line was down)."""

from __future__ import annotations

import asyncio
from typing import Any

from robostar.serve import LineConfig, Quality
from robostar.serve.line import Line

from .line_fakes import wait_for
from .test_line_queue import _Unpluggable


def test_online_false_stays_good_when_the_cable_is_pulled_during_polls() -> None:
    plug = _Unpluggable()

    async def main() -> None:
        line = Line(
            LineConfig("cell1", "sim://", poll_interval=0.02, slow_interval=0.05),
            client_factory=plug.client,
        )
        await line.start()
        try:
            await line.wait_polled()
            seen: list[tuple[str, Any, Quality]] = []
            with line.model.subscribe() as changes:

                async def watch() -> None:
                    async for change in changes:
                        seen.append((change.key, change.sample.value, change.sample.quality))

                watcher = asyncio.ensure_future(watch())
                plug.broken = True
                assert await wait_for(lambda: not line.up)
                await asyncio.sleep(0.5)  # polls failing, reopening failing
                watcher.cancel()
            online = [(value, quality) for key, value, quality in seen if key == "online"]
            assert (False, Quality.GOOD) in online, seen
            assert online[-1] == (False, Quality.GOOD), online
            now = line.model.get("online")
            assert now is not None and now.value is False and now.quality is Quality.GOOD
        finally:
            await line.stop()

    asyncio.run(main())
