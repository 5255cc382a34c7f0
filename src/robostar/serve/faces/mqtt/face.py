"""The MQTT face itself: a :class:`BrokerLink` per line, the server's presence, Sparkplug
(see the package's docstring for what it publishes)."""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
from collections.abc import Callable, Coroutine
from typing import TYPE_CHECKING, Any

import aiomqtt

from robostar.errors import UsageError
from robostar.serve.faces.mqtt.broker_link import BrokerLink
from robostar.serve.faces.mqtt.connection import (
    check_cancelled,
    keep_connected,
    new_client,
)
from robostar.serve.faces.mqtt.settings import MqttSettings
from robostar.serve.faces.mqtt.sparkplug.node import SparkplugNode
from robostar.serve.faces.mqtt.sparkplug.session import rebirth_request
from robostar.serve.faces.mqtt.topics import Topics
from robostar.serve.lease import Who

if TYPE_CHECKING:
    from robostar.serve.line_server import LineServer

__all__ = ["MqttFace"]

log = logging.getLogger("robostar.serve.mqtt")

ALONE_WAIT = 1.0
"""How long a start listens for another server's birth under its prefix or Sparkplug node."""


class MqttFace:
    """Publishes every line of ``server`` to one broker (see the package's docstring)."""

    def __init__(self, server: LineServer, settings: MqttSettings) -> None:
        self.server = server
        self.settings = settings
        self.topics = Topics(settings.prefix)
        self.links: dict[str, BrokerLink] = {}
        self.tasks: set[asyncio.Task[Any]] = set()
        self._pumps: list[asyncio.Task[None]] = []
        """The lines' value pumps: a stop ends them first, so no value follows the offline."""
        self._stopping = False
        self.presence: aiomqtt.Client | None = None
        self.who = Who(settings.client_id, "mqtt")
        """The name commands run and are audited under (MQTT does not say who sent one)."""
        self.sparkplug: SparkplugNode | None = None
        if settings.sparkplug is not None:
            self.sparkplug = SparkplugNode(
                dict(server.lines), settings, settings.sparkplug, self.who
            )

    def client(self, identifier: str, will_topic: str | None) -> aiomqtt.Client:
        """A client as ``identifier``; its last will says ``false`` on ``will_topic``."""
        will = None if will_topic is None else aiomqtt.Will(will_topic, b"false", 1, True)
        return new_client(self.settings, identifier, will)

    def _spawn(
        self,
        name: str,
        job: Callable[[], Coroutine[Any, Any, None]],
        group: list[asyncio.Task[None]] | None = None,
    ) -> None:
        """Run ``job()`` as one of the face's tasks, for as long as the face runs: a task that
        ends by an error (a bug, an error nobody foresaw) would otherwise end a line's values
        or commands for good, silently. It is logged and started again a second later."""
        task = asyncio.create_task(job(), name=f"mqtt {name}")
        self.tasks.add(task)
        if group is not None:
            group.append(task)

        def ended(done: asyncio.Task[None]) -> None:
            self.tasks.discard(done)
            if group is not None and done in group:
                group.remove(done)
            if self._stopping or done.cancelled():
                return
            exc = done.exception()
            log.error(
                "mqtt face: task %s ended (%r); starting it again in 1 s",
                name,
                exc,
                exc_info=exc,
            )
            restart = lambda: None if self._stopping else self._spawn(name, job, group)  # noqa: E731
            asyncio.get_running_loop().call_later(1.0, restart)

        task.add_done_callback(ended)

    async def start(self) -> None:
        await self._check_alone()
        # The server's birth first: a subscriber that sees a line's values sees the server's.
        self._spawn("server presence", self._server_presence)
        for name, line in self.server.lines.items():
            link = self.links[name] = BrokerLink(self, line)
            self._spawn(f"{name} pump", link.pump, self._pumps)
            self._spawn(f"{name} connection", link.connect_loop)
            requests = link.requests
            if self.settings.commands:
                for lane_name, lane in requests.lanes.items():
                    self._spawn(
                        f"{name} {lane_name}",
                        functools.partial(requests.work, lane),
                        requests.workers,
                    )
                self._spawn(f"{name} answers", requests.answer_loop)
            if requests.stop_names:
                self._spawn(f"{name} stops connection", requests.stop_loop)
        node = self.sparkplug
        if node is not None:
            self._spawn("sparkplug node", node.run)
            for name in node.devices:
                pump = functools.partial(node.pump, name)
                self._spawn(f"sparkplug {name} pump", pump, self._pumps)
                if self.settings.commands:
                    self._spawn(f"sparkplug {name} commands", functools.partial(node.work, name))
                    stops = functools.partial(node.work, name, stops=True)
                    self._spawn(f"sparkplug {name} stops", stops)
        log.info(
            "mqtt face: %d line(s) to %s:%d",
            len(self.links),
            self.settings.host,
            self.settings.port,
        )

    async def _check_alone(self) -> None:
        """:meth:`_look_for_another`, bounded: a broker that does not answer in time (or a
        connect that hangs) leaves it unchecked, logged, rather than holding up the start."""
        probe = asyncio.create_task(self._look_for_another())
        done, _ = await asyncio.wait({probe}, timeout=self.settings.publish_timeout + ALONE_WAIT)
        if probe in done:
            probe.result()  # the refusal, if another server is there
            return
        probe.cancel()
        log.warning("mqtt face: the broker did not answer in time; another server not looked for")

    async def _look_for_another(self) -> None:
        """Refuse to start beside another server online under the same prefix or Sparkplug
        node on this broker: their values, commands and births would mix. The retained
        ``<prefix>/_server/online`` tells of a JSON tree (its will says false when it dies); a
        Sparkplug node is asked to be born again (NCMD rebirth), and a live one answers with
        an NBIRTH. A broker out of reach is no reason not to start (store and forward)."""
        online = self.topics.server("online")
        # A message of our own after the subscriptions: the broker sends the retained ones
        # before it, so once it is back there is no retained birth left to wait for.
        marker = self.topics.server(f"probe/{self.settings.client_id}")
        node = self.sparkplug
        births = None if node is None else node.topics.of_node("NBIRTH")
        found: list[str] = []
        loop = asyncio.get_running_loop()
        try:
            async with self.client(f"{self.settings.client_id}-probe", None) as probe:
                await probe.subscribe(online, qos=1)
                await probe.subscribe(marker, qos=1)
                if node is not None and births is not None:
                    await probe.subscribe(births, qos=0)
                    await probe.publish(node.topics.of_node("NCMD"), rebirth_request(), qos=1)
                await probe.publish(marker, b"", qos=1)
                # A live node answers the rebirth request within the wait; a JSON tree's
                # retained birth is in before the marker.
                deadline = loop.time() + (ALONE_WAIT if node is not None else 10.0)
                messages = aiter(probe.messages)
                marked = False
                while not found and (left := deadline - loop.time()) > 0:
                    waiter = asyncio.ensure_future(anext(messages))
                    done, _ = await asyncio.wait({waiter}, timeout=left)
                    if not done:
                        waiter.cancel()
                        break
                    message = waiter.result()
                    topic = str(message.topic)
                    if topic == marker:
                        marked = True
                        if node is None:
                            break
                    elif topic == online and message.payload == b"true":
                        found.append(f"a server is online under the prefix {self.topics.prefix!r}")
                    elif node is not None and topic == births:
                        group, name = node.topics.group, node.topics.node
                        found.append(f"the Sparkplug node {group}/{name} is online")
                if not marked and not found:
                    log.warning("mqtt face: the broker did not echo the probe; not checked")
        except (aiomqtt.MqttError, TimeoutError) as exc:
            log.warning("mqtt face: could not look for another server on the broker (%s)", exc)
            return
        if found:
            raise UsageError(
                f"mqtt: {found[0]} on {self.settings.host}:{self.settings.port}; give this server"
                " another prefix or Sparkplug node id (two servers there would mix their values"
                " and commands)"
            )

    async def _server_presence(self) -> None:
        online = self.topics.server("online")

        async def present(client: aiomqtt.Client) -> None:
            await client.publish(online, b"true", qos=1, retain=True)
            self.presence = client
            check_cancelled()  # a stop swallowed by the connect (see keep_connected)
            async for _ in client.messages:
                pass

        def lost() -> None:
            self.presence = None

        await keep_connected(
            "server presence",
            lambda: self.client(f"{self.settings.client_id}-server", online),
            present,
            lost,
            self.settings.reconnect_max,
        )

    async def stop(self) -> None:
        """Say offline (retained) where connected, then disconnect: a clean stop is not a
        death, but the lines are not served any more either."""
        self._stopping = True  # no task is started again from here
        # The pumps end first: one still running could publish the model's ``online`` (true)
        # after the offline below, and the retained state would say the line is served.
        pumps = list(self._pumps)
        for task in pumps:
            task.cancel()
        await asyncio.gather(*pumps, return_exceptions=True)
        for link in self.links.values():
            await link.values.say_stopped()
            client = link.values.client
            if client is not None:
                with contextlib.suppress(aiomqtt.MqttError, TimeoutError):
                    await client.publish(
                        self.topics.online(link.line.name),
                        b"false",
                        qos=1,
                        retain=True,
                        timeout=2.0,
                    )
        if self.sparkplug is not None:
            await self.sparkplug.say_death()
        presence = self.presence
        if presence is not None:
            with contextlib.suppress(aiomqtt.MqttError, TimeoutError):
                await presence.publish(
                    self.topics.server("online"), b"false", qos=1, retain=True, timeout=2.0
                )
        tasks = list(self.tasks)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        self.tasks.clear()
        for link in self.links.values():
            link.values.buffer.close()
