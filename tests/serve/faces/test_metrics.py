"""The metrics face against a web page on another name (DNS rebinding): real HTTP requests
against a running face, the same Host rule as the API and the dashboard."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import Any

import httpx
import pytest

from robostar.errors import UsageError
from robostar.serve import LineConfig, LineServer, ServeConfig


def _run(
    test: Callable[[str, int, httpx.AsyncClient], Awaitable[None]],
    metrics: dict[str, Any] | None = None,
) -> None:
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.05),),
        faces={"metrics": {"listen": "127.0.0.1:0", **(metrics or {})}},
    )

    async def main() -> None:
        async with LineServer(config) as server:
            host, port = server.faces["metrics"].address  # type: ignore[attr-defined]
            async with httpx.AsyncClient(timeout=10) as http:
                await test(host, port, http)

    asyncio.run(main())


async def _raw(port: int, head: str) -> bytes:
    """Sends ``head`` as is (httpx would add its own Host) and reads the whole answer."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        writer.write(head.encode("latin-1"))
        await writer.drain()
        return await asyncio.wait_for(reader.read(), 5)
    finally:
        writer.close()


def test_a_foreign_host_header_is_refused_and_shows_no_figures() -> None:
    async def test(host: str, port: int, http: httpx.AsyncClient) -> None:
        url = f"http://{host}:{port}/metrics"
        for name in (f"evil.example:{port}", "evil.example", "127.0.0.1.evil.example", ""):
            answer = await http.get(url, headers={"Host": name})
            assert answer.status_code == 400, name
            assert "does not answer to the host" in answer.text
            assert "robostar_line_up" not in answer.text
        for name in (f"localhost:{port}", f"127.0.0.1:{port}", f"[::1]:{port}", "LOCALHOST"):
            answer = await http.get(url, headers={"Host": name})
            assert answer.status_code == 200, name
            assert 'robostar_line_up{line="cell1"}' in answer.text
        # no Host at all (HTTP/1.0), or two of them: refused as well
        for head in (
            "GET /metrics HTTP/1.0\r\n\r\n",
            f"GET /metrics HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nHost: evil.example\r\n\r\n",
        ):
            answer = await _raw(port, head)
            assert answer.startswith(b"HTTP/1.1 400 "), answer[:60]
            assert b"robostar_line_up" not in answer

    _run(test)


def test_the_hosts_option_adds_names_and_the_token_is_asked_after_the_host() -> None:
    async def test(host: str, port: int, http: httpx.AsyncClient) -> None:
        url = f"http://{host}:{port}/metrics"
        # a foreign name is refused before the token is looked at: the page learns nothing
        answer = await http.get(
            url, headers={"Host": "evil.example", "Authorization": "Bearer s3cret"}
        )
        assert answer.status_code == 400
        answer = await http.get(url, headers={"Host": "cell7.plant.example"})
        assert answer.status_code == 401  # a configured name, still without the token
        answer = await http.get(
            url, headers={"Host": "cell7.plant.example:9464", "Authorization": "Bearer s3cret"}
        )
        assert answer.status_code == 200 and "robostar_line_up" in answer.text

    _run(test, {"hosts": ["cell7.plant.example"], "token": "s3cret"})


def test_a_bad_hosts_option_is_named() -> None:
    from tests.serve.conftest import sim_server

    from robostar.serve.faces import metrics as metrics_face

    with pytest.raises(UsageError, match=r"metrics\.hosts"):
        metrics_face.create(sim_server(), {"listen": "127.0.0.1:0", "hosts": [1]})
