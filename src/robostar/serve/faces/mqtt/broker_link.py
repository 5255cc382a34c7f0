"""One line at the broker: its connection (birth, replay, then commands), its values and its
commands, for :class:`~robostar.serve.faces.mqtt.face.MqttFace`."""

from __future__ import annotations

import asyncio
import logging
from typing import TYPE_CHECKING

import aiomqtt

from robostar.serve.faces.mqtt.buffer import StoreAndForward
from robostar.serve.faces.mqtt.connection import check_cancelled, command_options, keep_connected
from robostar.serve.faces.mqtt.publisher import ValuePublisher
from robostar.serve.faces.mqtt.reporter import Reporter
from robostar.serve.faces.mqtt.requests import CommandRequests, Lane
from robostar.serve.model import Sample

if TYPE_CHECKING:
    from robostar.serve.faces.mqtt.face import MqttFace
    from robostar.serve.line import Line

__all__ = ["BrokerLink"]

log = logging.getLogger("robostar.serve.mqtt")


class BrokerLink:
    """One line at the broker: its connection (birth, replay, then commands), its values
    (:class:`ValuePublisher`) and its commands (:class:`CommandRequests`)."""

    def __init__(self, face: MqttFace, line: Line) -> None:
        self.face = face
        self.line = line
        self.values = ValuePublisher(line, face.settings, face.topics)
        self.requests = CommandRequests(
            line, face.settings, face.topics, face.who, lambda name: face.client(name, None)
        )

    # The parts' state, by the names the face has always shown (the tests and bench read them).
    @property
    def client(self) -> aiomqtt.Client | None:
        return self.values.client

    @client.setter
    def client(self, client: aiomqtt.Client | None) -> None:
        self.values.client = client

    @property
    def buffer(self) -> StoreAndForward:
        return self.values.buffer

    @property
    def reporter(self) -> Reporter:
        return self.values.reporter

    @property
    def kicked(self) -> asyncio.Event:
        return self.values.kicked

    @property
    def published(self) -> int:
        return self.values.published

    @property
    def buffer_lost(self) -> int:
        return self.values.buffer_lost

    @property
    def replaying(self) -> bool:
        return self.values.replaying

    async def send(self, key: str, sample: Sample) -> None:
        await self.values.send(key, sample)

    @property
    def lanes(self) -> dict[str, Lane]:
        return self.requests.lanes

    @property
    def workers(self) -> list[asyncio.Task[None]]:
        return self.requests.workers

    @property
    def stop_names(self) -> frozenset[str]:
        return self.requests.stop_names

    @property
    def stop_client(self) -> aiomqtt.Client | None:
        return self.requests.stop_client

    async def pump(self) -> None:
        """The line's values, for as long as the face runs (see :meth:`ValuePublisher.pump`)."""
        await self.values.pump()

    async def connect_loop(self) -> None:
        def lost() -> None:
            self.values.connection_lost()

        client_id = f"{self.face.settings.client_id}-{self.line.name}"
        online = self.face.topics.online(self.line.name)
        await keep_connected(
            self.line.name,
            lambda: self.face.client(client_id, online),
            self._serve_connection,
            lost,
            self.face.settings.reconnect_max,
        )

    async def _serve_connection(self, client: aiomqtt.Client) -> None:
        """One connection of the line's values and commands: birth, replay, then commands."""
        settings = self.face.settings
        topics = self.face.topics
        values = self.values
        # A kick is about the connection before this one (a publish that failed while there
        # was none): it must not end this one.
        values.kicked.clear()
        born = await values.birth(client)  # info, then online: once per connection
        if settings.commands:
            await client.subscribe(topics.commands(self.line.name), options=command_options())
        await values.replay(client)
        values.go_live(client, born)
        log.info("mqtt %s: connected to %s:%d", self.line.name, settings.host, settings.port)
        check_cancelled()  # (the publishes and the replay above use wait_for too)
        reader = asyncio.create_task(self.requests.read(client))
        kicked = asyncio.create_task(values.kicked.wait())
        try:
            done, _ = await asyncio.wait({reader, kicked}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            reader.cancel()
            kicked.cancel()
        values.kicked.clear()
        if reader in done:
            reader.result()  # the connection's error
