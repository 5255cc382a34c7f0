"""Staleness only when asked for: a read is answered by the controller unless its asker accepts
an older value (Line.read's max_age, the API's max_age in the body or the query, serve://'s
?max_age=), and then it gets the value's age with it; a line's config max_age no longer makes
every consumer's reads stale."""

from __future__ import annotations

import asyncio
import time

import httpx
import pytest

from robostar import AsyncClient
from robostar.commands.control import ReadSpeed
from robostar.commands.status import ReadStatus
from robostar.errors import UsageError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.transport.opener import async_transport_for_url

from .conftest import sim_server


def test_a_read_without_max_age_goes_to_the_controller_whatever_the_config_says() -> None:
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=5.0, max_age=60.0),), faces={}
    )

    async def main() -> None:
        async with LineServer(config) as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            before = line.health.exchanges
            for _ in range(3):
                await line.read(ReadStatus())
            assert line.health.exchanges == before + 3

    asyncio.run(main())


def test_a_read_with_max_age_is_answered_from_the_model_with_its_time() -> None:
    async def main() -> None:
        async with sim_server(poll_interval=5.0) as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            sample = line.model.get("ch1/speed")
            assert sample is not None
            before = line.health.exchanges
            value, at = await line.read_sample(ReadSpeed(1), max_age=60)
            assert (value, at) == (sample.value, sample.at)
            assert line.health.exchanges == before

    asyncio.run(main())


def _api_config() -> ServeConfig:
    lines = (LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0),)
    return ServeConfig(lines=lines, faces={"api": {"listen": "127.0.0.1:0"}})


def test_the_api_gives_a_reads_age_and_takes_max_age_in_the_body_or_the_query() -> None:
    read = {"command": "ReadSpeed", "args": {"channel": 1}}

    async def main() -> None:
        async with LineServer(_api_config()) as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            url = f"http://{host}:{port}/lines/cell1/commands"
            async with httpx.AsyncClient(timeout=10) as http:
                await asyncio.sleep(0.3)
                before = line.health.exchanges
                fresh = (await http.post(url, json=read)).json()
                assert line.health.exchanges == before + 1
                assert fresh["result"] == 300 and fresh["age_ms"] < 300
                old = (await http.post(url, json={**read, "max_age": 60})).json()
                queried = (await http.post(f"{url}?max_age=60", json=read)).json()
                assert line.health.exchanges == before + 1
                assert old["result"] == 300 and old["age_ms"] >= 0
                assert queried["result"] == 300 and "age_ms" in queried
                bad = await http.post(f"{url}?max_age=soon", json=read)
                assert bad.status_code == 400 and "max_age" in bad.text

    asyncio.run(main())


def test_the_api_gives_a_model_answers_true_age() -> None:
    read = {"command": "ReadSpeed", "args": {"channel": 1}, "max_age": 60}

    async def main() -> tuple[float, float]:
        async with LineServer(_api_config()) as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            async with httpx.AsyncClient(timeout=10) as http:
                await asyncio.sleep(0.3)
                sample = line.model.get("ch1/speed")
                assert sample is not None
                answer = await http.post(f"http://{host}:{port}/lines/cell1/commands", json=read)
                return answer.json()["age_ms"], (time.time() - sample.at) * 1000

    age_ms, true_age_ms = asyncio.run(main())
    assert 300 <= age_ms <= true_age_ms


def test_serve_urls_max_age_reads_from_the_model_and_without_it_from_the_controller() -> None:
    async def main() -> tuple[int, int]:
        async with LineServer(_api_config()) as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            counts = []
            for query in ("?max_age=60", ""):
                async with AsyncClient(f"serve://{host}:{port}/cell1{query}") as client:
                    await client.status()
                    before = line.health.exchanges
                    for _ in range(5):
                        await client.status()
                    counts.append(line.health.exchanges - before)
            return counts[0], counts[1]

    relaxed, linearizable = asyncio.run(main())
    assert (relaxed, linearizable) == (0, 5)


@pytest.mark.parametrize("bad", ["-1", "nan", "soon"])
def test_a_bad_serve_max_age_is_a_clear_error(bad: str) -> None:
    with pytest.raises(UsageError, match="max_age"):
        async_transport_for_url(f"serve://127.0.0.1:8470/cell1?max_age={bad}")
