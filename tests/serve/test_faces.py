"""The N1 and API faces: host programs through the server, lease conflicts, SSE, serve:// URLs."""

from __future__ import annotations

import asyncio
import json
import urllib.error
import urllib.request
from typing import Any

import pytest

from robostar import Client
from robostar.errors import FunctionFailedError, UsageError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces import create_face


def _config(**faces: dict[str, Any]) -> ServeConfig:
    return ServeConfig(lines=(LineConfig("cell1", "sim://", poll_interval=0.05),), faces=faces)


def _n1_url(server: LineServer) -> str:
    host, port = server.faces["n1"].addresses["cell1"]  # type: ignore[attr-defined]
    return f"tcp://{host}:{port}"


def test_a_second_host_is_refused_with_0x32_and_kd_names_the_holder() -> None:
    async def main() -> None:
        async with LineServer(_config(n1={"lines": {"cell1": "127.0.0.1:0"}})) as server:
            url = _n1_url(server)

            def hosts() -> None:
                with Client(url, timeout=1.0) as first, Client(url, timeout=1.0) as second:
                    first.set_speed(1, 40)  # takes the lease implicitly
                    assert second.speed(1) == 40  # reads need no lease
                    with pytest.raises(FunctionFailedError) as caught:
                        second.set_speed(1, 90)
                    assert "held by n1:" in str(caught.value)
                    assert "held by n1:" in second.last_error()
                    assert first.speed(1) == 40
                # the first host went away: its lease is free again
                with Client(url, timeout=1.0) as third:
                    third.set_speed(1, 90)
                    assert third.speed(1) == 90

            await asyncio.to_thread(hosts)

    asyncio.run(main())


def test_serve_url_reaches_a_line_through_the_api() -> None:
    async def main() -> None:
        async with LineServer(_config(api={"listen": "127.0.0.1:0"})) as server:
            host, port = server.faces["api"].address  # type: ignore[attr-defined]

            def through() -> None:
                with Client(f"serve://{host}:{port}/cell1") as client:
                    client.set_speed(1, 61)
                    assert client.speed(1) == 61
                    assert client.info().name == "N1-SIM"
                with pytest.raises(Exception, match="no line 'nope'"):
                    Client(f"serve://{host}:{port}/nope").connect()

            await asyncio.to_thread(through)

    asyncio.run(main())


def _call(url: str, body: dict[str, Any] | None = None, method: str = "GET", **headers: str) -> Any:
    data = None if body is None else json.dumps(body).encode()
    if method != "GET":  # the API takes state changes as JSON only (a web page cannot send it)
        headers = {"Content-Type": "application/json", **headers}
    request = urllib.request.Request(url, data=data, method=method, headers=headers)
    try:
        with urllib.request.urlopen(request, timeout=5) as reply:
            return reply.status, json.loads(reply.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


def test_the_api_serves_the_model_commands_and_the_lease() -> None:
    async def main() -> None:
        async with LineServer(_config(api={"listen": "127.0.0.1:0"})) as server:
            await server.lines["cell1"].wait_polled()
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            base = f"http://{host}:{port}/lines/cell1"

            def calls() -> None:
                status, body = _call(base)
                assert status == 200
                assert body["model"]["ch1/speed"]["value"] == 300
                assert body["model"]["ch1/status"]["quality"] == "good"
                set_speed = {"command": "SetSpeed", "args": {"channel": 1, "speed": 20}}
                status, body = _call(f"{base}/commands", set_speed, "POST")
                assert status == 409  # no lease, none implied
                status, body = _call(f"{base}/lease", None, "POST", **{"X-Robostar-Who": "ann"})
                assert status == 200 and body["who"] == "ann"
                status, body = _call(
                    f"{base}/commands", set_speed, "POST", **{"X-Robostar-Who": "bob"}
                )
                assert status == 409 and "ann" in body["message"]
                status, body = _call(
                    f"{base}/commands", set_speed, "POST", **{"X-Robostar-Who": "ann"}
                )
                assert status == 200
                read = {"command": "ReadSpeed", "args": {"channel": 1}}
                status, answer = _call(f"{base}/commands", read, "POST")
                assert (status, answer["result"]) == (200, 20) and answer["age_ms"] >= 0
                bad = {"command": "SetSpeed", "args": {"channel": 9, "speed": 20}}
                status, body = _call(f"{base}/commands", bad, "POST", **{"X-Robostar-Who": "ann"})
                assert status == 400 and "channel" in body["message"]
                status, _ = _call(f"http://{host}:{port}/lines/nope")
                assert status == 404

            await asyncio.to_thread(calls)

    asyncio.run(main())


def test_the_api_streams_model_changes_as_sse() -> None:
    async def main() -> None:
        async with LineServer(_config(api={"listen": "127.0.0.1:0"})) as server:
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            reader, writer = await asyncio.open_connection(host, port)
            writer.write(f"GET /lines/cell1/events HTTP/1.1\r\nHost: {host}\r\n\r\n".encode())
            await writer.drain()
            seen: set[str] = set()
            async with asyncio.timeout(10):
                while "ch1/status" not in seen or "online" not in seen:
                    line = await reader.readline()
                    if line.startswith(b"data: "):
                        seen.add(json.loads(line[6:])["key"])
            writer.close()
            await asyncio.sleep(0.1)
            # the closed stream's subscription is gone (the poller never writes into it again)
            async with asyncio.timeout(5):
                while server.lines["cell1"].model.subscribers:
                    await server.lines["cell1"].wait_polled()

    asyncio.run(main())


def test_a_token_is_required_when_configured() -> None:
    async def main() -> None:
        config = _config(api={"listen": "127.0.0.1:0", "token": "s3cret"})
        async with LineServer(config) as server:
            host, port = server.faces["api"].address  # type: ignore[attr-defined]

            def calls() -> None:
                assert _call(f"http://{host}:{port}/lines")[0] == 401
                ok = _call(f"http://{host}:{port}/lines", Authorization="Bearer s3cret")
                assert ok[0] == 200

            await asyncio.to_thread(calls)

    asyncio.run(main())


def test_an_unknown_or_missing_face_is_a_clear_error() -> None:
    async def main() -> None:
        async with LineServer(_config()) as server:
            with pytest.raises(UsageError, match="unknown face"):
                create_face("telex", server, {})
            with pytest.raises(UsageError, match=r"api\.listen"):
                create_face("api", server, {})
            with pytest.raises(UsageError, match=r"n1\.lines\.nope"):
                create_face("n1", server, {"lines": {"nope": "127.0.0.1:0"}})
            with pytest.raises(UsageError, match="beyond loopback needs a token"):
                create_face("api", server, {"listen": "0.0.0.0:0", "allow_remote": True})

    asyncio.run(main())
