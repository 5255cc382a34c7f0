"""The N1 face's [n1] max_clients and idle_timeout reach the host that serves each line."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from robostar import AsyncClient
from robostar.errors import FunctionFailedError, UsageError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces import create_face

pytestmark = pytest.mark.timeout(30)


def _server(**faces: dict[str, Any]) -> LineServer:
    return LineServer(
        ServeConfig(lines=(LineConfig("cell1", "sim://", poll_interval=0.05),), faces=faces)
    )


@pytest.mark.parametrize(
    ("key", "bad"), [("max_clients", 0), ("max_clients", "2"), ("idle_timeout", -1.0)]
)
def test_a_bad_limit_is_a_clear_error(key: str, bad: object) -> None:
    with pytest.raises(UsageError, match=rf"n1\.{key}"):
        create_face("n1", _server(), {"lines": {"cell1": "127.0.0.1:0"}, key: bad})


def test_max_clients_from_the_config_turns_the_next_host_away_with_a_clear_refusal() -> None:
    async def main() -> None:
        options = {"lines": {"cell1": "127.0.0.1:0"}, "max_clients": 1, "idle_timeout": 0}
        server = _server(n1=options)
        await server.start()
        try:
            face = server.faces["n1"]
            host, port = face.addresses["cell1"]  # type: ignore[attr-defined]
            assert face.hosts["cell1"].idle_timeout is None  # type: ignore[attr-defined]
            async with AsyncClient(f"tcp://{host}:{port}") as first:
                await first.status()
                async with AsyncClient(f"tcp://{host}:{port}") as second:
                    with pytest.raises(FunctionFailedError, match="already 1 clients"):
                        await second.status()
                await first.status()  # the first is still served
        finally:
            await server.stop()

    asyncio.run(main())
