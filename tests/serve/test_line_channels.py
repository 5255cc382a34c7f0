"""A line shows the channels its controller has: on a 2-channel controller there is no channel 3
in the model (so MQTT publishes no ch3/status, the web page offers no channel 3), whatever the
configuration names; AA is still answered whole from the model when a read accepts it."""

from __future__ import annotations

import asyncio

from robostar.commands.status import ReadStatus
from robostar.serve import LineConfig, LineServer, ServeConfig

from .line_fakes import first_poll


def _server(channels: dict[int, str]) -> LineServer:
    line = LineConfig("cell1", "sim://?channels=2", poll_interval=5.0, channels=channels)
    return LineServer(ServeConfig(lines=(line,), faces={}))


def test_a_two_channel_controller_has_no_channel_three_in_the_model() -> None:
    async def main() -> None:
        async with _server({}) as server:
            line = server.lines["cell1"]
            await first_poll(line)
            assert line.channels() == (1, 2)
            keys = line.model.snapshot().keys()
            assert {"ch1/status", "ch2/status"} <= keys
            assert not [key for key in keys if key.startswith("ch3/")]
            before = line.health.exchanges
            status = await line.read(ReadStatus(), max_age=60)
            assert len(status) == 3 and line.health.exchanges == before

    asyncio.run(main())


def test_configured_channels_the_controller_lacks_are_not_shown() -> None:
    async def main() -> None:
        async with _server({1: "loader", 3: "unloader"}) as server:
            line = server.lines["cell1"]
            await first_poll(line)
            assert line.channels() == (1,)
            assert not [key for key in line.model.snapshot() if key.startswith("ch3/")]

    asyncio.run(main())
