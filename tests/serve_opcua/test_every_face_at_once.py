"""The plant's picture: one process owns the line and serves every face at once — an existing
N1 host program, the JSON API, Prometheus, the MQTT broker, OPC UA and the dashboard — and a
change made through one face is seen through the others."""

from __future__ import annotations

import asyncio
import json
import socket
import urllib.request
from pathlib import Path
from typing import Any

import aiomqtt
import pytest
from asyncua import ua
from tests.serve_mqtt.conftest import MOSQUITTO, Broker

from robostar import Client
from robostar.serve import LineConfig, LineServer, ServeConfig

from .conftest import Model, Setup, connect, until

pytestmark = [
    pytest.mark.timeout(120),
    pytest.mark.skipif(MOSQUITTO is None, reason="mosquitto is not installed"),
]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _http(
    url: str, body: dict[str, Any] | None = None, method: str | None = None, **headers: str
) -> tuple[int, bytes]:
    data = None if body is None else json.dumps(body).encode()
    verb = method or ("GET" if body is None else "POST")
    request = urllib.request.Request(url, data=data, method=verb, headers=headers)
    with urllib.request.urlopen(request, timeout=5) as reply:
        return reply.status, reply.read()


def test_every_face_serves_the_same_line_at_once(opcua_setup: Setup, tmp_path: Path) -> None:
    broker = Broker(tmp_path)
    broker.start()
    web_port = _free_port()
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=0.05),),
        faces={
            "n1": {"lines": {"cell1": "127.0.0.1:0"}},
            "api": {"listen": "127.0.0.1:0"},
            "metrics": {"listen": "127.0.0.1:0"},
            "mqtt": {"url": broker.url},
            "opcua": {
                "listen": "127.0.0.1:0",
                "users": str(opcua_setup.users),
                "state_dir": str(opcua_setup.state),
                "cache_dir": str(opcua_setup.cache),
            },
            "web": {"listen": f"127.0.0.1:{web_port}", "users": str(opcua_setup.users)},
        },
    )

    async def main() -> None:
        async with LineServer(config) as server, connect(server, opcua_setup) as opcua:
            faces: Any = server.faces
            n1_host, n1_port = faces["n1"].addresses["cell1"]
            api_host, api_port = faces["api"].address
            metrics_host, metrics_port = faces["metrics"].address
            api = f"http://{api_host}:{api_port}/lines/cell1"
            speeds: list[Any] = []

            async def mqtt_listener(ready: asyncio.Event) -> None:
                async with aiomqtt.Client("127.0.0.1", broker.port) as sub:
                    await sub.subscribe("robostar/cell1/ch1/speed", qos=1)
                    ready.set()
                    async for message in sub.messages:
                        payload = message.payload
                        assert isinstance(payload, bytes)
                        speeds.append(json.loads(payload)["value"])

            ready = asyncio.Event()
            listener = asyncio.create_task(mqtt_listener(ready))
            await asyncio.wait_for(ready.wait(), 10)

            def other_consumers() -> None:
                # an N1 host program, unchanged, through the N1 face
                with Client(f"tcp://{n1_host}:{n1_port}") as n1:
                    assert len(n1.status()) == 3
                # the API: a speed change under a lease, the model read back
                who = {"X-Robostar-Who": "ann", "Content-Type": "application/json"}
                assert _http(f"{api}/lease", {}, **who)[0] == 200
                change = {"command": "SetSpeed", "args": {"channel": 1, "speed": 420}}
                assert _http(f"{api}/commands", change, **who)[0] == 200
                assert _http(f"{api}/lease", None, "DELETE", **who)[0] == 200
                status, body = _http(f"http://{metrics_host}:{metrics_port}/metrics")
                assert status == 200 and b'robostar_line_up{line="cell1"} 1.0' in body
                status, body = _http(f"http://127.0.0.1:{web_port}/")
                assert status == 200 and b"cell1" in body

            await asyncio.to_thread(other_consumers)
            speed = await Model(opcua).path(
                "rob:MotionDevices", "ven:Channel1", "di:ParameterSet", "rob:SpeedOverride"
            )

            async def seen_everywhere() -> bool:
                data = await speed.read_data_value(raise_on_bad_status=False)
                return data.Value.Value == 42.0 and 420 in speeds

            await until(seen_everywhere, what="the API's change in OPC UA and MQTT")
            data = await speed.read_data_value()
            assert data.StatusCode.value == ua.StatusCodes.Good
            listener.cancel()

    try:
        asyncio.run(main())
    finally:
        broker.stop()
