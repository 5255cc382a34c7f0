"""A line's values in the JSON tree: model changes -> reporter -> broker, or the buffer.

The pump reads the line's model subscription and publishes each change the reporter lets
through (report by exception, deadband, rate cap), retained, as JSON with its time and quality.
While there is no connection, changes wait in the store-and-forward buffer; the next connection
replays them in order, marked historical, before anything live.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import sqlite3
import time
from typing import TYPE_CHECKING, Any

import aiomqtt

from robostar.serve.faces.mqtt.buffer import StoreAndForward
from robostar.serve.faces.mqtt.connection import REPLAY_WINDOW, check_cancelled, wait_event
from robostar.serve.faces.mqtt.control import watch_control
from robostar.serve.faces.mqtt.leaves import channel_of, robot_of
from robostar.serve.faces.mqtt.payload import OFFLINE, encode
from robostar.serve.faces.mqtt.reporter import Reporter
from robostar.serve.faces.mqtt.settings import MqttSettings
from robostar.serve.faces.mqtt.topics import Topics
from robostar.serve.model import Sample
from robostar.types import IOState

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["ValuePublisher"]

log = logging.getLogger("robostar.serve.mqtt")


class ValuePublisher:
    """One line's values: its reporter, buffer, pump, and the replay of what waited."""

    def __init__(self, line: Line, settings: MqttSettings, topics: Topics) -> None:
        self.line = line
        self.settings = settings
        self.topics = topics
        path = settings.buffer
        if path != ":memory:":
            os.makedirs(path, exist_ok=True)
            path = os.path.join(path, f"{line.name}.sqlite")
        self.buffer = StoreAndForward(path, max_rows=settings.buffer_rows)
        self.reporter = Reporter(deadband=settings.deadband, max_rate=settings.rate)
        self.client: aiomqtt.Client | None = None
        """The connection values go out on (None: none, changes go to the buffer)."""
        self._not_replaying = asyncio.Event()
        """Clear while a replay runs: the pump then leaves changes in the reporter (the latest
        per topic) instead of adding them to the buffer behind the replay."""
        self._not_replaying.set()
        self.published = 0
        self.wake = asyncio.Event()
        self.kicked = asyncio.Event()
        """Set when a publish failed: the connection is dropped and made again (then replayed)."""
        self.buffer_lost = 0
        """Changes the buffer could not take (an SQLite error: a full disk): lost, counted."""
        self._lost_logged = 0.0
        self._started = asyncio.Event()
        """Set once the first connection is made or has failed: until then changes wait in the
        reporter (the latest per topic), so a start with the broker up sends live values, not
        a buffer of history made while connecting."""
        self._sent: dict[str, Sample] = {}
        """What each value topic last said (a clean stop says it again, offline)."""
        self._lost = asyncio.Event()
        """Set while there is no connection (a publish still waiting on the last one ends)."""
        self._lost.set()
        self._contacts: dict[str, tuple[bool, ...]] = {}
        """Each I/O port's contacts as last published one topic per signal."""

    def connection_lost(self) -> None:
        """The connection went: no publish waits for it any more; changes go to the buffer."""
        self.client = None
        self._lost.set()
        self._started.set()

    @property
    def replaying(self) -> bool:
        return not self._not_replaying.is_set()

    async def birth(self, client: aiomqtt.Client) -> dict[str, Sample]:
        """The line's birth on a new connection: ``info``, then ``online`` (bare true/false,
        as the last will says it), retained, before anything else; what it published."""
        snapshot = self.line.model.snapshot()
        born: dict[str, Sample] = {}
        info = snapshot.get("info")
        if info is not None:
            await client.publish(
                self.topics.value(self.line.name, "info"),
                encode(info),
                qos=self.settings.qos,
                retain=True,
                timeout=self.settings.publish_timeout,
            )
            born["info"] = info
        online = snapshot.get("online")
        up = self.line.up if online is None else bool(online.value)
        await client.publish(
            self.topics.online(self.line.name),
            b"true" if up else b"false",
            qos=1,
            retain=True,
            timeout=self.settings.publish_timeout,
        )
        if online is not None:
            born["online"] = online
        return born

    def go_live(self, client: aiomqtt.Client, born: dict[str, Sample]) -> None:
        """Publish on ``client`` from now on, starting with the whole current state again
        (but what the birth said: ``online`` once per connection)."""
        self.client = client
        self._lost.clear()
        self._started.set()
        self.reporter.forget()  # the current state goes out again, retained
        self._contacts.clear()
        for key, sample in born.items():
            self.reporter.mark_sent(key, sample)
            if key != "online":
                self._sent[key] = sample
        for key, sample in self.line.model.snapshot().items():
            self.reporter.offer(key, sample)
        self.wake.set()

    async def say_stopped(self) -> None:
        """A clean stop: every value (and every I/O signal) said again, retained, with the
        quality ``offline``."""
        client = self.client
        if client is None:
            return
        messages = [
            (key, encode(sample, robot=robot_of(self.line.info, key), quality=OFFLINE))
            for key, sample in self._sent.items()
        ]
        for key, contacts in self._contacts.items():
            at = self._sent[key].at if key in self._sent else time.time()
            messages += [
                (f"{key}/{contact}", encode(Sample(on, at), quality=OFFLINE))
                for contact, on in enumerate(contacts)
            ]
        await asyncio.gather(
            *(
                client.publish(
                    self.topics.value(self.line.name, key),
                    payload,
                    qos=self.settings.qos,
                    retain=True,
                    timeout=2.0,
                )
                for key, payload in messages
            ),
            return_exceptions=True,
        )

    async def pump(self) -> None:
        with self.line.model.subscribe(maxsize=10_000) as changes:
            for key, sample in self.line.model.snapshot().items():
                self.reporter.offer(key, sample)
            feeder = asyncio.create_task(self._feed(changes))
            watcher = asyncio.create_task(watch_control(self.line, self.reporter, self.wake))
            try:
                while True:
                    check_cancelled()
                    if not self._started.is_set():
                        await self._started.wait()
                        continue
                    if self.replaying:
                        # Live changes wait in the reporter; the replay ends by offering the
                        # current state again, so nothing here is lost or sent twice.
                        await self._not_replaying.wait()
                        continue
                    now = time.monotonic()
                    for key, sample in self.reporter.due(now):
                        await self.send(key, sample)
                    due = self.reporter.next_due(now)
                    self.wake.clear()
                    timeout = None if due is None else max(0.0, due - time.monotonic())
                    await wait_event(self.wake, timeout)
            finally:
                feeder.cancel()
                watcher.cancel()

    async def _feed(self, changes: Any) -> None:
        async for change in changes:
            self.reporter.offer(change.key, change.sample)
            self.wake.set()

    async def send(self, key: str, sample: Sample) -> None:
        channel = channel_of(key)
        if channel is not None and channel not in self.line.channels():
            return  # a channel the controller does not have
        topic = self.topics.value(self.line.name, key)
        # ``online`` is the birth/death topic: a bare true/false, as the last will says it.
        online = key == "online"
        robot = robot_of(self.line.info, key)
        payload = (b"true" if sample.value else b"false") if online else encode(sample, robot=robot)
        if self.replaying:
            # Taken from the reporter just before a replay began: the current state is offered
            # again when the replay ends, so this adds nothing the broker will not get.
            return
        client = self.client
        if client is None:  # only while not connected: a replay drains what is in the buffer
            if not online:  # a line's state while the broker was away is history
                self._keep(topic, encode(sample, historical=True, robot=robot))
            return
        try:
            await self._publish_while_connected(client, topic, payload)
            self.published += 1
            if not online:
                self._sent[key] = sample
            if isinstance(sample.value, IOState):
                await self._send_signals(client, key, sample)
        except (aiomqtt.MqttError, TimeoutError) as exc:
            check_cancelled()
            if self.client is client:
                log.warning("mqtt %s: publish failed (%s); buffering", self.line.name, exc)
                self.client = None
                self.kicked.set()
            elif self.client is not None or self.replaying:
                # A late failure of a connection that is already gone (its publish timed out
                # after the face connected again): the new connection is fine, and it sends
                # the current state anyway, so this change is neither buffered nor a reason to
                # drop it.
                log.info(
                    "mqtt %s: a publish on the old connection failed (%s)", self.line.name, exc
                )
                return
            if not online:
                self._keep(topic, encode(sample, historical=True, robot=robot))

    async def _publish_while_connected(
        self, client: aiomqtt.Client, topic: str, payload: bytes
    ) -> None:
        """Publish a value, retained; MqttError at once when the connection is lost meanwhile.
        aiomqtt lets a publish wait for its acknowledgement until ``publish_timeout`` even after
        the connection went: the pump would be held that long while the model's changes
        coalesce, and the buffer would miss all but the last of them."""
        publishing = asyncio.ensure_future(
            client.publish(
                topic,
                payload,
                qos=self.settings.qos,
                retain=True,
                timeout=self.settings.publish_timeout,
            )
        )
        lost = asyncio.ensure_future(self._lost.wait())
        try:
            await asyncio.wait({publishing, lost}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            lost.cancel()
            if not publishing.done():
                publishing.cancel()
        if publishing.cancelled():
            check_cancelled()
            raise aiomqtt.MqttError("the connection was lost before the broker acknowledged")
        publishing.result()

    async def _send_signals(self, client: aiomqtt.Client, key: str, sample: Sample) -> None:
        """An I/O port's contacts, one topic per signal beside the port (``io/in/0/3``): those
        that changed since they were last published."""
        contacts = tuple(sample.value.contacts)
        last = self._contacts.get(key)
        self._contacts[key] = contacts
        for contact, on in enumerate(contacts):
            if last is not None and contact < len(last) and last[contact] == on:
                continue
            await self._publish_while_connected(
                client,
                self.topics.value(self.line.name, f"{key}/{contact}"),
                encode(Sample(on, sample.at, sample.quality)),
            )
            self.published += 1

    def _keep(self, topic: str, payload: bytes) -> None:
        """Buffer a change for the replay. An SQLite error (a full disk) loses this change,
        counted and logged, rather than ending the pump (and every later value with it)."""
        try:
            self.buffer.put(topic, payload, False)
        except sqlite3.Error as exc:
            self.buffer_lost += 1
            now = time.monotonic()
            if now >= self._lost_logged + 10.0:
                self._lost_logged = now
                log.error(
                    "mqtt %s: a change was not buffered (%s); %d lost so far",
                    self.line.name,
                    exc,
                    self.buffer_lost,
                )

    async def replay(self, client: aiomqtt.Client) -> None:
        """Send what waited, in order, before anything live: the rows up to the newest one when
        the replay begins (changes meanwhile wait in the reporter, so it always ends), a window
        of them out at once (one round trip per window, not per row)."""
        self._not_replaying.clear()
        try:
            upto = self.buffer.last_id()
            while upto is not None:
                batch = [row for row in self.buffer.peek(REPLAY_WINDOW) if row.id <= upto]
                if not batch:
                    break
                outcomes = await asyncio.gather(
                    *(
                        client.publish(
                            row.topic,
                            row.payload,
                            qos=self.settings.qos,
                            retain=row.retain,
                            timeout=self.settings.publish_timeout,
                        )
                        for row in batch
                    ),
                    return_exceptions=True,
                )
                # What went out is out: a broken replay resumes without it, never repeats it.
                sent = [
                    row.id
                    for row, outcome in zip(batch, outcomes, strict=True)
                    if not isinstance(outcome, BaseException)
                ]
                if sent:
                    self.buffer.remove_ids(sent)
                for outcome in outcomes:
                    if isinstance(outcome, BaseException):
                        raise outcome
            if self.buffer.dropped or self.buffer_lost:
                status = {
                    "line": self.line.name,
                    "dropped": self.buffer.dropped,
                    "not_buffered": self.buffer_lost,
                }
                await client.publish(
                    self.topics.server("buffer"), json.dumps(status).encode(), qos=1
                )
        finally:
            self._not_replaying.set()
