"""A real Mosquitto per test on a free loopback port (Debian's ``mosquitto``; CI installs it),
and the set-up the command tests share: a line server whose MQTT face takes commands
(:func:`serving`) and an MQTT 5 client that sends them and keeps the replies (:class:`Requester`).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import shutil
import socket
import subprocess
import time
from collections.abc import AsyncIterator, Callable, Iterator
from pathlib import Path
from typing import Any

import aiomqtt
import pytest
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties

from robostar.serve import LineConfig, LineServer, ServeConfig

MOSQUITTO = shutil.which("mosquitto") or (
    "/usr/sbin/mosquitto" if Path("/usr/sbin/mosquitto").exists() else None
)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Broker:
    """A mosquitto process that can be stopped and started again on the same port."""

    def __init__(self, directory: Path) -> None:
        self.port = _free_port()
        self.config = directory / "mosquitto.conf"
        self.config.write_text(
            f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence false\n"
        )
        self.process: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self) -> None:
        assert MOSQUITTO is not None
        self.process = subprocess.Popen(
            [MOSQUITTO, "-c", str(self.config)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.2):
                    return
            except OSError:
                time.sleep(0.05)
        raise RuntimeError("mosquitto did not start")

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            try:
                self.process.wait(5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(5)
            self.process = None


@pytest.fixture
def broker(tmp_path: Path) -> Iterator[Broker]:
    if MOSQUITTO is None:
        pytest.skip("Debian's mosquitto is not installed (apt-get install mosquitto; CI does)")
    b = Broker(tmp_path)
    b.start()
    try:
        yield b
    finally:
        b.stop()


async def until(check: Callable[[], bool], seconds: float = 10.0) -> None:
    end = time.monotonic() + seconds
    while not check():
        if time.monotonic() > end:
            raise AssertionError("the condition did not come true in time")
        await asyncio.sleep(0.02)


RESULTS = "robostar/cell1/cmd/+/result"


def commands_config(broker: Broker, audit: Path, **commands: Any) -> ServeConfig:
    """One ``sim://`` line, the MQTT face with commands on (``speed`` allowed unless ``allow``
    says otherwise; ``commands`` are the ``[mqtt.commands]`` options), the audit log."""
    options = {"enabled": True, "allow": ["speed"], **commands}
    return ServeConfig(
        lines=(LineConfig("cell1", "sim://?speedup=20", poll_interval=0.05),),
        faces={"mqtt": {"url": broker.url, "client_id": "cell-robostar", "commands": options}},
        audit_path=str(audit),
    )


async def connected(server: LineServer) -> Any:
    """The MQTT face's link of ``cell1``, once it is connected to the broker."""
    link = server.faces["mqtt"].links["cell1"]  # type: ignore[attr-defined]
    # The stops have a connection of their own: wait for it too when there is one.
    await until(lambda: link.client is not None and (not link.stop_names or link.stop_client))
    return link


@contextlib.asynccontextmanager
async def serving(
    broker: Broker, audit: Path, **commands: Any
) -> AsyncIterator[tuple[LineServer, Any]]:
    """A running line server of :func:`commands_config`, and its connected MQTT link."""
    async with LineServer(commands_config(broker, audit, **commands)) as server:
        yield server, await connected(server)


class Requester:
    """An MQTT 5 client that sends commands and keeps every reply (topic, body, correlation)."""

    def __init__(self, client: aiomqtt.Client) -> None:
        self.client = client
        self.replies: list[tuple[str, dict[str, Any], bytes | None]] = []

    @classmethod
    @contextlib.asynccontextmanager
    async def connect(cls, broker: Broker, *patterns: str) -> AsyncIterator[Requester]:
        """Connected and subscribed to ``patterns`` (the result topics and ``replies/#``)
        while the block runs."""
        async with contextlib.AsyncExitStack() as stack:
            client = aiomqtt.Client(
                "127.0.0.1",
                broker.port,
                protocol=aiomqtt.ProtocolVersion.V5,
                max_queued_outgoing_messages=None,
            )
            await stack.enter_async_context(client)
            for pattern in patterns or (RESULTS, "replies/#"):
                await client.subscribe(pattern, qos=1)
            requester = cls(client)
            task = asyncio.create_task(requester._collect())
            stack.callback(task.cancel)
            yield requester

    async def _collect(self) -> None:
        async for message in self.client.messages:
            raw = message.payload
            assert isinstance(raw, bytes)
            corr = getattr(message.properties, "CorrelationData", None)
            self.replies.append((str(message.topic), json.loads(raw), corr))

    def by_id(self, request_id: Any) -> list[tuple[str, dict[str, Any], bytes | None]]:
        return [r for r in self.replies if r[1].get("id") == request_id]

    async def send(
        self,
        name: str,
        payload: bytes,
        *,
        response_topic: str | None = None,
        correlation: bytes | None = None,
        qos: int = 1,
    ) -> None:
        props = None
        if response_topic is not None or correlation is not None:
            props = Properties(PacketTypes.PUBLISH)  # type: ignore[no-untyped-call]
            if response_topic is not None:
                props.ResponseTopic = response_topic
            if correlation is not None:
                props.CorrelationData = correlation
        await self.client.publish(f"robostar/cell1/cmd/{name}", payload, qos=qos, properties=props)


class LatencyProxy:
    """A TCP proxy on loopback that delays every chunk by ``delay`` seconds each way: a broker
    across a plant network, where a round trip per message is what costs."""

    def __init__(self, upstream_port: int, delay: float) -> None:
        self.upstream_port = upstream_port
        self.delay = delay
        self.port = 0
        self._server: asyncio.Server | None = None
        self._tasks: set[asyncio.Task[None]] = set()

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    async def start(self) -> None:
        self._server = await asyncio.start_server(self._serve, "127.0.0.1", 0)
        self.port = int(self._server.sockets[0].getsockname()[1])

    async def stop(self) -> None:
        if self._server is not None:
            self._server.close()
        for task in list(self._tasks):
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        await asyncio.sleep(0)

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        assert task is not None
        self._tasks.add(task)
        try:
            try:
                up_reader, up_writer = await asyncio.open_connection(
                    "127.0.0.1", self.upstream_port
                )
            except OSError:
                writer.close()
                return
            await asyncio.gather(
                self._pipe(reader, up_writer), self._pipe(up_reader, writer), return_exceptions=True
            )
        except asyncio.CancelledError:
            # Stopped: end quietly (asyncio's stream callback reports a cancelled handler).
            writer.close()
        finally:
            self._tasks.discard(task)

    async def _pipe(self, source: asyncio.StreamReader, sink: asyncio.StreamWriter) -> None:
        loop = asyncio.get_running_loop()
        chunks: asyncio.Queue[tuple[float, bytes]] = asyncio.Queue()

        async def later() -> None:
            while True:
                due, data = await chunks.get()
                if not data:
                    break
                await asyncio.sleep(max(0.0, due - loop.time()))
                sink.write(data)
                await sink.drain()

        writer = asyncio.create_task(later())
        try:
            while data := await source.read(65536):
                chunks.put_nowait((loop.time() + self.delay, data))
        except OSError:
            pass
        finally:
            chunks.put_nowait((0.0, b""))
            with contextlib.suppress(OSError, asyncio.CancelledError):
                await writer
            writer.cancel()
            sink.close()
