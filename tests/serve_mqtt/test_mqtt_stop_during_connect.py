"""A stop that lands while the face is connecting ends the server: on Python 3.11 a cancellation
racing with aiomqtt's own timeouts (asyncio.wait_for) can be swallowed, and the connection
task must not then wait on the new connection for ever."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from typing import Any

import pytest

from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.mqtt import MqttFace

pytestmark = pytest.mark.timeout(60)


class SwallowingClient:
    """Connects as an aiomqtt client can on 3.11 when a stop races its CONNACK timeout: the
    cancellation is swallowed and the connection comes up anyway."""

    def __init__(self, connecting: asyncio.Event) -> None:
        self.connecting = connecting
        self.messages = self._messages()

    async def __aenter__(self) -> SwallowingClient:
        self.connecting.set()
        with contextlib.suppress(asyncio.CancelledError):  # as asyncio.wait_for can on 3.11
            await asyncio.Event().wait()
        return self

    async def __aexit__(self, *_: Any) -> None:
        return None

    async def publish(self, *_: Any, **__: Any) -> None:
        return None

    async def subscribe(self, *_: Any, **__: Any) -> None:
        return None

    async def _messages(self) -> AsyncIterator[Any]:
        await asyncio.Event().wait()
        yield None


def test_a_stop_during_a_connect_ends(monkeypatch: pytest.MonkeyPatch) -> None:
    async def main() -> None:
        connecting = asyncio.Event()
        monkeypatch.setattr(MqttFace, "client", lambda *_: SwallowingClient(connecting))
        config = ServeConfig(
            lines=(LineConfig("cell1", "sim://", poll_interval=0.05),),
            faces={"mqtt": {"url": "mqtt://127.0.0.1:1"}},
        )
        stop = asyncio.Event()

        async def serve() -> None:
            async with LineServer(config):
                await stop.wait()

        serving = asyncio.create_task(serve())
        await asyncio.wait_for(connecting.wait(), 10)
        stop.set()
        done, _ = await asyncio.wait({serving}, timeout=10)
        assert serving in done, "the server did not stop"
        serving.result()

    asyncio.run(main())
