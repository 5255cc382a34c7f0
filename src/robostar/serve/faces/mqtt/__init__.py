"""The MQTT face: the lines' live models in the plant's broker, and optional write-back.

``robostar serve --mqtt mqtt://HOST:PORT`` (or ``[mqtt]`` in the config) publishes every line's
model under ``<prefix>/<line>/...`` (docs/mqtt.md): retained JSON values with their time and
quality, reported by exception (a deadband on positions, a rate cap per line), a retained
``online`` per line with a last will, and ``<prefix>/_server/online``. While the broker is away,
changes wait in a bounded SQLite buffer and are replayed in order, marked historical. Commands
are off unless the configuration turns them on, per name.

Each line has its own MQTT connection (its own last will) and a pump task that reads the
line's model subscription, so a slow or silent broker never holds up a line's worker.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import json
import logging
import os
import sqlite3
import ssl
import time
from collections.abc import Awaitable, Callable, Coroutine, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any
from urllib.parse import urlsplit

import aiomqtt
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties
from paho.mqtt.subscribeoptions import SubscribeOptions

from robostar.commands.base import Command
from robostar.errors import RobostarError, UsageError
from robostar.serve.faces.mqtt.buffer import StoreAndForward
from robostar.serve.faces.mqtt.commands import COMMANDS, ESTOP, make_command, read_params
from robostar.serve.faces.mqtt.payload import encode
from robostar.serve.faces.mqtt.reporter import Reporter
from robostar.serve.faces.mqtt.topics import Topics, check_prefix, response_topic_problem
from robostar.serve.jsonable import jsonable
from robostar.serve.lease import Who
from robostar.serve.model import Sample

if TYPE_CHECKING:
    from robostar.serve.line import Line
    from robostar.serve.line_server import LineServer

__all__ = ["BusyError", "MqttFace", "MqttSettings", "create"]

log = logging.getLogger("robostar.serve.mqtt")

_OPTIONS = frozenset(
    (
        "url",
        "prefix",
        "client_id",
        "username",
        "password",
        "password_env",
        "ca",
        "cert",
        "key",
        "qos",
        "deadband",
        "rate",
        "buffer",
        "buffer_rows",
        "commands",
        "publish_timeout",
        "reconnect_max",
        "allow_remote",
        "token",
    )
)
_COMMAND_OPTIONS = frozenset(("enabled", "allow", "estop", "max_pending", "max_payload"))
_STOP_NAMES = frozenset((ESTOP, "stop_job"))
"""Commands that jump every queue at the line: they have their own lane in the face too."""
REPLAY_WINDOW = 100
"""Buffered rows a replay has out at once: one round trip per window, not one per row (paho
keeps its own in-flight limit beneath), and a bounded number of publishes waiting."""
PACKET_OVERHEAD = 65_535 + 64
"""What the Maximum Packet Size the face announces allows beyond ``max_payload``: a topic
name's most (65,535 bytes) and a fixed header's and a few properties' worth."""
ANSWER_QUEUE = 64
"""Refusals the readers made, waiting for their answer to be published (per line). A reader
never waits on an answer's QoS 1 round trip; past this bound an answer is dropped (counted and
logged; the refusal is still audited)."""
INCOMING_QUEUE = 256
"""aiomqtt's own queue of received messages per connection. Past it the client discards what
arrives (logged once in a while: QueueFullFilter), so a flood costs bounded memory even before
the face reads it."""


@dataclass(frozen=True)
class MqttSettings:
    host: str
    port: int
    tls: bool = False
    prefix: str = "robostar"
    client_id: str = "robostar"
    username: str | None = None
    password: str | None = field(default=None, repr=False)
    ca: str | None = None
    cert: str | None = None
    key: str | None = None
    qos: int = 1
    deadband: float = 0.01
    rate: float = 50.0
    buffer: str = ":memory:"
    buffer_rows: int = 100_000
    commands: frozenset[str] = frozenset()
    max_pending: int = 16
    """Commands per line waiting or running in the face (stops count apart); past it: busy."""
    max_payload: int = 16_384
    """The largest command payload read (bytes); a bigger one is refused unread."""
    publish_timeout: float = 5.0
    reconnect_max: float = 30.0
    """The longest wait between reconnection attempts (the wait doubles from 0.5 s)."""


def _number(options: Mapping[str, Any], key: str, default: float, low: float) -> float:
    value = options.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float) or not value >= low:
        raise UsageError(f"mqtt.{key}: {value!r} is not a number of at least {low:g}")
    return float(value)


def _count(options: Mapping[str, Any], key: str, default: int, low: int) -> int:
    value = options.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise UsageError(f"mqtt.commands.{key}: {value!r} is not an integer of at least {low}")
    return value


def settings_from(options: Mapping[str, Any]) -> MqttSettings:
    """The face's settings, every key checked (UsageError naming it)."""
    unknown = sorted(set(options) - _OPTIONS)
    if unknown:
        raise UsageError(
            f"mqtt.{unknown[0]}: unknown option (options: {', '.join(sorted(_OPTIONS))})"
        )
    url = str(options.get("url", ""))
    parts = urlsplit(url)
    if parts.scheme not in ("mqtt", "mqtts") or not parts.hostname:
        raise UsageError(f"mqtt.url: {url!r} is not mqtt://HOST[:PORT] or mqtts://HOST[:PORT]")
    tls = parts.scheme == "mqtts"
    try:
        port = parts.port or (8883 if tls else 1883)
    except ValueError:
        raise UsageError(f"mqtt.url: {url!r} has a bad port") from None
    password = options.get("password")
    env = options.get("password_env")
    if env is not None:
        password = os.environ.get(str(env))
        if password is None:
            raise UsageError(f"mqtt.password_env: the environment has no {env}")
    commands_option = options.get("commands", {})
    if not isinstance(commands_option, Mapping):
        raise UsageError("mqtt.commands: expected a table (enabled, allow, estop)")
    bad = sorted(set(commands_option) - _COMMAND_OPTIONS)
    if bad:
        raise UsageError(
            f"mqtt.commands.{bad[0]}: unknown option ({', '.join(sorted(_COMMAND_OPTIONS))})"
        )
    commands: set[str] = set()
    if commands_option.get("enabled", False) is True:
        allow = commands_option.get("allow", [])
        if isinstance(allow, str) or not all(name in COMMANDS for name in allow):
            raise UsageError(
                f"mqtt.commands.allow: {allow!r}: names among {', '.join(sorted(COMMANDS))}"
            )
        commands.update(allow)
        if commands_option.get("estop", False) is True:
            commands.add(ESTOP)
    cert, key, ca = options.get("cert"), options.get("key"), options.get("ca")
    if (cert or key) and not (tls or ca):
        # Only mqtts:// or ca turn TLS on: a certificate on an mqtt:// URL would be silently
        # unused, and the face would connect in clear, its password too.
        # (Named by host and port only: the URL may hold a password.)
        raise UsageError(
            f"mqtt.{'cert' if cert else 'key'}: client certificates need TLS: use"
            f" mqtts://{parts.hostname}:{port} (or set mqtt.ca); an mqtt:// URL connects in clear"
        )
    if key and not cert:
        raise UsageError("mqtt.key: a key without mqtt.cert (the client certificate) is unused")
    qos = options.get("qos", 1)
    if qos not in (0, 1, 2):
        raise UsageError(f"mqtt.qos: {qos!r} is not 0, 1 or 2")
    return MqttSettings(
        host=parts.hostname,
        port=port,
        tls=tls or bool(ca),
        prefix=check_prefix(str(options.get("prefix", "robostar"))),
        client_id=str(options.get("client_id", "robostar")),
        username=options.get("username") or parts.username,
        password=password or parts.password,
        ca=ca,
        cert=cert,
        key=key,
        qos=int(qos),
        deadband=_number(options, "deadband", 0.01, 0.0),
        rate=_number(options, "rate", 50.0, 0.1),
        buffer=str(options.get("buffer", ":memory:")),
        buffer_rows=int(_number(options, "buffer_rows", 100_000, 1)),
        commands=frozenset(commands),
        max_pending=_count(commands_option, "max_pending", 16, 1),
        max_payload=_count(commands_option, "max_payload", 16_384, 16),
        publish_timeout=_number(options, "publish_timeout", 5.0, 0.1),
        reconnect_max=_number(options, "reconnect_max", 30.0, 0.1),
    )


def _check_cancelled() -> None:
    """Raise CancelledError if this task was asked to stop. On Python 3.11 a cancellation that
    races with a timeout inside asyncio.wait_for (which aiomqtt's publish uses) comes out as a
    timeout; a loop that handles timeouts must look for it, or a stop would wait forever."""
    task = asyncio.current_task()
    if task is not None and task.cancelling():
        raise asyncio.CancelledError


async def _wait_event(event: asyncio.Event, timeout: float | None) -> None:
    """Wait until ``event`` is set or ``timeout`` passes. Not wait_for nor asyncio.timeout: on
    Python 3.11 both can swallow a cancellation that races with the event or the timeout, and
    a stop would then wait forever for this task. asyncio.wait never does."""
    waiter = asyncio.ensure_future(event.wait())
    try:
        await asyncio.wait({waiter}, timeout=timeout)
    finally:
        waiter.cancel()


def _command_options() -> SubscribeOptions:
    """How the face subscribes to command topics. A retained command would run again at every
    reconnect and restart: the broker is told not to send retained messages on subscribe
    (retain handling 2), and to keep the retain flag as published (so a retained command that
    arrives live is seen as such, and refused)."""
    return SubscribeOptions(
        qos=1,
        retainAsPublished=True,
        retainHandling=SubscribeOptions.RETAIN_DO_NOT_SEND,
    )


def _short(text: str, size: int = 80) -> str:
    """A name from the wire, cut to a size fit for a message or the audit log."""
    return text if len(text) <= size else f"{text[:size]}..."


class QueueFullFilter(logging.Filter):
    """aiomqtt logs every message it discards from its full queue: a flood would write a line
    per message. This lets one through per ``every`` seconds, with how many it held back."""

    def __init__(self, every: float = 10.0) -> None:
        super().__init__()
        self.every = every
        self.held = 0
        self._next = 0.0

    def filter(self, record: logging.LogRecord) -> bool:
        if not record.getMessage().startswith("Message queue is full"):
            return True
        now = time.monotonic()
        if now < self._next:
            self.held += 1
            return False
        self._next = now + self.every
        if self.held:
            record.msg = f"{record.getMessage()} ({self.held:,} more since the last report)"
            record.args = ()
            self.held = 0
        return True


client_log = logging.getLogger("robostar.serve.mqtt.client")
"""The logger of the face's MQTT clients (aiomqtt's messages)."""
client_log.addFilter(QueueFullFilter())


class BusyError(RobostarError):
    """The face already has as many commands waiting or running for a line as it takes."""


@dataclass
class _Lane:
    """One line's queue of command messages, run one at a time by a worker task. ``pending``
    counts those waiting or running; the reader refuses more than ``limit``."""

    limit: int
    pending: int = 0
    queue: asyncio.Queue[tuple[aiomqtt.Client, aiomqtt.Message, str]] = field(
        default_factory=asyncio.Queue
    )


class _BrokerLink:
    """One line's connection, buffer, pump and command lanes."""

    def __init__(self, face: MqttFace, line: Line) -> None:
        self.face = face
        self.line = line
        settings = face.settings
        path = settings.buffer
        if path != ":memory:":
            os.makedirs(path, exist_ok=True)
            path = os.path.join(path, f"{line.name}.sqlite")
        self.buffer = StoreAndForward(path, max_rows=settings.buffer_rows)
        self.reporter = Reporter(deadband=settings.deadband, max_rate=settings.rate)
        self.client: aiomqtt.Client | None = None
        self._not_replaying = asyncio.Event()
        """Clear while a replay runs: the pump then leaves changes in the reporter (the latest
        per topic) instead of adding them to the buffer behind the replay."""
        self._not_replaying.set()
        self.published = 0
        self.wake = asyncio.Event()
        self.kicked = asyncio.Event()
        """Set when a publish failed: the connection is dropped and made again (then replayed)."""
        self.lanes = {
            "commands": _Lane(settings.max_pending),
            "stops": _Lane(settings.max_pending),
        }
        self.workers: list[asyncio.Task[None]] = []
        self.stop_names = _STOP_NAMES & settings.commands
        """The enabled stops: they come in on a connection of their own (its own subscription
        and queue), so a flood of other commands never fills the queue a stop waits in."""
        self.stop_client: aiomqtt.Client | None = None
        self.answers: asyncio.Queue[
            tuple[aiomqtt.Client, aiomqtt.Message, str, dict[str, Any], Any]
        ] = asyncio.Queue(maxsize=ANSWER_QUEUE)
        self.answers_dropped = 0
        self._answers_logged = 0.0
        self.buffer_lost = 0
        """Changes the buffer could not take (an SQLite error: a full disk): lost, counted."""
        self._lost_logged = 0.0

    @property
    def replaying(self) -> bool:
        return not self._not_replaying.is_set()

    # -- the pump: model changes -> reporter -> broker or buffer -----------------------------
    async def pump(self) -> None:
        with self.line.model.subscribe(maxsize=10_000) as changes:
            for key, sample in self.line.model.snapshot().items():
                self.reporter.offer(key, sample)
            feeder = asyncio.create_task(self._feed(changes))
            try:
                while True:
                    _check_cancelled()
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
                    await _wait_event(self.wake, timeout)
            finally:
                feeder.cancel()

    async def _feed(self, changes: Any) -> None:
        async for change in changes:
            self.reporter.offer(change.key, change.sample)
            self.wake.set()

    async def send(self, key: str, sample: Sample) -> None:
        topic = self.face.topics.value(self.line.name, key)
        # ``online`` is the birth/death topic: a bare true/false, as the last will says it.
        online = key == "online"
        payload = (b"true" if sample.value else b"false") if online else encode(sample)
        if self.replaying:
            # Taken from the reporter just before a replay began: the current state is offered
            # again when the replay ends, so this adds nothing the broker will not get.
            return
        client = self.client
        if client is None:  # only while not connected: a replay drains what is in the buffer
            if not online:  # a line's state while the broker was away is history
                self._keep(topic, encode(sample, historical=True))
            return
        try:
            await client.publish(
                topic,
                payload,
                qos=self.face.settings.qos,
                retain=True,
                timeout=self.face.settings.publish_timeout,
            )
            self.published += 1
        except (aiomqtt.MqttError, TimeoutError) as exc:
            _check_cancelled()
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
                self._keep(topic, encode(sample, historical=True))

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

    # -- the connection ------------------------------------------------------------------------
    async def _keep_connected(
        self,
        label: str,
        client_id: str,
        will: str | None,
        session: Callable[[aiomqtt.Client], Awaitable[None]],
        lost: Callable[[], None],
    ) -> None:
        """Connect as ``client_id`` (last will on topic ``will``, if any) and run ``session`` on
        the connection until it fails; then ``lost()`` and again, backing off up to
        ``reconnect_max`` (reset once a connection is made)."""
        backoff = 0.5
        while True:
            try:
                async with self.face.client(client_id, will) as client:
                    # A stop that raced the connect may have been swallowed (aiomqtt's
                    # wait_for on 3.11): look before waiting on this connection for good.
                    _check_cancelled()
                    backoff = 0.5
                    await session(client)
            except (aiomqtt.MqttError, TimeoutError) as exc:  # a replay's publish may time out
                _check_cancelled()
                log.warning("mqtt %s: %s; retrying in %.1f s", label, exc, backoff)
            finally:
                lost()
            await asyncio.sleep(backoff)
            backoff = min(backoff * 2, self.face.settings.reconnect_max)

    async def connect_loop(self) -> None:
        settings = self.face.settings
        online = self.face.topics.online(self.line.name)

        def lost() -> None:
            self.client = None

        await self._keep_connected(
            self.line.name,
            f"{settings.client_id}-{self.line.name}",
            online,
            self._serve_connection,
            lost,
        )

    async def _serve_connection(self, client: aiomqtt.Client) -> None:
        """One connection of the line's values and commands: birth, replay, then commands."""
        settings = self.face.settings
        topics = self.face.topics
        online = topics.online(self.line.name)
        # A kick is about the connection before this one (a publish that failed while there
        # was none): it must not end this one.
        self.kicked.clear()
        up = b"true" if self.line.up else b"false"
        await client.publish(online, up, qos=1, retain=True)
        if settings.commands:
            await client.subscribe(topics.commands(self.line.name), options=_command_options())
        await self._replay(client)
        self.client = client
        self.reporter.forget()  # the current state goes out again, retained
        for key, sample in self.line.model.snapshot().items():
            self.reporter.offer(key, sample)
        self.wake.set()
        log.info("mqtt %s: connected to %s:%d", self.line.name, settings.host, settings.port)
        _check_cancelled()  # (the publishes and the replay above use wait_for too)
        reader = asyncio.create_task(self._read(client))
        kicked = asyncio.create_task(self.kicked.wait())
        try:
            done, _ = await asyncio.wait({reader, kicked}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            reader.cancel()
            kicked.cancel()
        self.kicked.clear()
        if reader in done:
            reader.result()  # the connection's error

    async def stop_loop(self) -> None:
        """The stops' own connection: subscribed to the enabled stops' topics only, so its
        client queue holds stops alone, whatever floods the other command topics."""

        async def serve_stops(client: aiomqtt.Client) -> None:
            for name in sorted(self.stop_names):
                await client.subscribe(
                    self.face.topics.command(self.line.name, name), options=_command_options()
                )
            self.stop_client = client
            _check_cancelled()
            await self._read(client, stops=True)

        def lost() -> None:
            self.stop_client = None

        # No last will: this connection's end says nothing about the line.
        client_id = f"{self.face.settings.client_id}-{self.line.name}-stops"
        await self._keep_connected(f"{self.line.name} (stops)", client_id, None, serve_stops, lost)

    async def _read(self, client: aiomqtt.Client, *, stops: bool = False) -> None:
        """Take command messages until the connection fails (MqttError). Nothing here waits on
        the line nor on the broker: a message goes to its lane, or is refused at once (not
        enabled, busy) with its answer left to the answer task."""
        async for message in client.messages:
            name = self.face.topics.command_name(str(message.topic), self.line.name)
            if name is None:
                continue
            if not stops and name in self.stop_names:
                continue  # the stops' own connection takes it (and answers it)
            if message.retain:
                problem = UsageError(
                    "a retained command message is refused (it would run again at every"
                    " reconnect); publish commands without retain"
                )
                self._refuse_later(client, message, name, problem)
                continue
            if name not in self.face.settings.commands:
                problem = UsageError(f"command {_short(name)!r} is not enabled on this server")
                self._refuse_later(client, message, name, problem)
                continue
            lane = self.lanes["stops" if name in _STOP_NAMES else "commands"]
            if lane.pending >= lane.limit:
                busy = BusyError(
                    f"busy: {lane.pending} MQTT commands are waiting or running on line"
                    f" {self.line.name} (the limit); not run, send it again later"
                )
                self._refuse_later(client, message, name, busy)
                continue
            lane.pending += 1
            lane.queue.put_nowait((client, message, name))
        raise aiomqtt.MqttError("the broker closed the connection")

    async def _replay(self, client: aiomqtt.Client) -> None:
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
                            qos=self.face.settings.qos,
                            retain=row.retain,
                            timeout=self.face.settings.publish_timeout,
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
                    self.face.topics.server("buffer"), json.dumps(status).encode(), qos=1
                )
        finally:
            self._not_replaying.set()

    # -- commands ---------------------------------------------------------------------------
    async def work(self, lane: _Lane) -> None:
        """Run ``lane``'s commands one at a time (the line runs one at a time anyway)."""
        while True:
            client, message, name = await lane.queue.get()
            try:
                await self._command(client, message, name)
            except Exception:  # a handler never dies silently, nor takes its lane with it
                _check_cancelled()
                log.exception("mqtt %s: command %s failed", self.line.name, _short(name))
            finally:
                lane.pending -= 1

    def _reply_topic(self, message: aiomqtt.Message, name: str) -> tuple[str, str | None]:
        """Where the answer goes, and what is wrong with the request's response topic (then
        the answer goes to the default result topic, and the command is refused)."""
        default = self.face.topics.result(self.line.name, name)
        requested = getattr(message.properties, "ResponseTopic", None)
        if requested is None:
            return default, None
        problem = response_topic_problem(str(requested), self.face.topics.prefix)
        if problem is not None:
            return default, f"the response topic {_short(str(requested))!r} {problem}"
        return str(requested), None

    def _payload(self, message: aiomqtt.Message) -> bytes:
        raw = message.payload
        payload = raw if isinstance(raw, bytes) else str(raw if raw is not None else "").encode()
        limit = self.face.settings.max_payload
        if len(payload) > limit:
            raise UsageError(
                f"bad payload: {len(payload):,} bytes, over the limit of {limit:,} bytes"
            )
        return payload

    def _request_id(self, message: aiomqtt.Message) -> Any:
        """The payload's ``"id"`` for a refusal's answer, when there is one to find."""
        try:
            return read_params(self._payload(message)).get("id")
        except RobostarError:
            return None

    async def answer_loop(self) -> None:
        """Publish the readers' refusals, one at a time, away from the readers."""
        while True:
            client, message, reply_to, body, request_id = await self.answers.get()
            await self._reply(client, message, reply_to, body, request_id)

    def _refuse_later(
        self, client: aiomqtt.Client, message: aiomqtt.Message, name: str, problem: RobostarError
    ) -> None:
        """A reader's refusal: audited now, answered by the answer task (dropped, counted,
        when too many wait). Never raises nor waits."""
        answer = self._refusal(message, name, problem)
        if answer is None:
            return
        try:
            self.answers.put_nowait((client, message, *answer))
        except asyncio.QueueFull:
            self.answers_dropped += 1
            now = time.monotonic()
            if now >= self._answers_logged + 10.0:
                self._answers_logged = now
                log.warning(
                    "mqtt %s: too many refusals to answer; %d answer(s) dropped so far"
                    " (each refusal is still audited)",
                    self.line.name,
                    self.answers_dropped,
                )

    async def _refuse(
        self,
        client: aiomqtt.Client,
        message: aiomqtt.Message,
        name: str,
        problem: RobostarError,
        command: Command[Any] | None = None,
        request_id: Any = None,
    ) -> None:
        """A worker's refusal: audited and answered."""
        answer = self._refusal(message, name, problem, command, request_id)
        if answer is not None:
            await self._reply(client, message, *answer)

    def _refusal(
        self,
        message: aiomqtt.Message,
        name: str,
        problem: RobostarError,
        command: Command[Any] | None = None,
        request_id: Any = None,
    ) -> tuple[str, dict[str, Any], Any] | None:
        """Audit a refusal of the face's own; the answer to send (None: none can be made).
        Never raises: the readers call it, and a reader must live as long as its connection."""
        try:
            what = command if command is not None else f"cmd/{_short(name)}"
            self.line.record(what, self.face.who, f"refused: {problem}")
        except Exception:  # the audit log's own trouble must not end the connection's reader
            log.exception("mqtt %s: a refusal was not audited", self.line.name)
        try:
            if request_id is None:
                request_id = self._request_id(message)
            reply_to, _ = self._reply_topic(message, name)
            body = {"ok": False, "error": str(problem), "kind": type(problem).__name__}
        except Exception:
            log.exception("mqtt %s: a refusal was not answered", self.line.name)
            return None
        return reply_to, body, request_id

    async def _command(self, client: aiomqtt.Client, message: aiomqtt.Message, name: str) -> None:
        reply_to, topic_problem = self._reply_topic(message, name)
        request_id: Any = None
        command: Command[Any] | None = None
        try:
            params = read_params(self._payload(message))
            request_id = params.get("id")
            if topic_problem is not None:
                raise UsageError(f"{topic_problem}; the command was not run")
            command = make_command(name, params)
            command.encode()  # every field's range, as the wire would refuse it
        except RobostarError as exc:
            await self._refuse(client, message, name, exc, command, request_id)
            return
        try:
            result = await self.line.execute(command, who=self.face.who, implicit_lease=True)
            body: dict[str, Any] = {"ok": True, "result": jsonable(result)}
        except RobostarError as exc:  # execute audited it
            body = {"ok": False, "error": str(exc), "kind": type(exc).__name__}
        except Exception as exc:
            log.exception("mqtt %s: %r failed", self.line.name, command)
            body = {"ok": False, "error": f"internal error: {exc!r}", "kind": "InternalError"}
        await self._reply(client, message, reply_to, body, request_id)

    async def _reply(
        self,
        client: aiomqtt.Client,
        message: aiomqtt.Message,
        reply_to: str,
        body: dict[str, Any],
        request_id: Any,
    ) -> None:
        """Publish an answer; a failure is logged, never raised."""
        if request_id is not None:
            body["id"] = request_id
        correlation = getattr(message.properties, "CorrelationData", None)
        properties = None
        if correlation is not None:
            properties = Properties(PacketTypes.PUBLISH)  # type: ignore[no-untyped-call]
            properties.CorrelationData = correlation
        try:
            await client.publish(
                reply_to, json.dumps(body).encode(), qos=1, properties=properties, timeout=5.0
            )
        except (aiomqtt.MqttError, TimeoutError) as exc:
            _check_cancelled()
            log.warning("mqtt %s: no answer sent to %s (%s)", self.line.name, reply_to, exc)
        except Exception:
            log.exception("mqtt %s: no answer sent to %s", self.line.name, reply_to)


class MqttFace:
    """Publishes every line of ``server`` to one broker (see the module's docstring)."""

    def __init__(self, server: LineServer, settings: MqttSettings) -> None:
        self.server = server
        self.settings = settings
        self.topics = Topics(settings.prefix)
        self.links: dict[str, _BrokerLink] = {}
        self.tasks: set[asyncio.Task[Any]] = set()
        self._stopping = False
        self.presence: aiomqtt.Client | None = None
        self.who = Who(settings.client_id, "mqtt")
        """The name commands run and are audited under (MQTT does not say who sent one)."""

    def client(self, identifier: str, will_topic: str | None) -> aiomqtt.Client:
        s = self.settings
        context = None
        if s.tls:
            context = ssl.create_default_context(cafile=s.ca)
            if s.cert:
                context.load_cert_chain(s.cert, s.key)
        # MQTT 5 Maximum Packet Size: the broker drops a message bigger than this instead of
        # sending it, so max_payload bounds memory before a message is read (else a flood of
        # big commands fills the client's queue with them). Room for the topic and properties
        # on top; a command past it gets no answer and no audit (the broker drops it).
        connect = Properties(PacketTypes.CONNECT)  # type: ignore[no-untyped-call]
        connect.MaximumPacketSize = s.max_payload + PACKET_OVERHEAD
        client = aiomqtt.Client(
            s.host,
            s.port,
            username=s.username,
            password=s.password,
            identifier=identifier,
            protocol=aiomqtt.ProtocolVersion.V5,
            will=None if will_topic is None else aiomqtt.Will(will_topic, b"false", 1, True),
            tls_context=context,
            keepalive=10,
            timeout=s.publish_timeout,
            max_queued_incoming_messages=INCOMING_QUEUE,
            logger=client_log,
            properties=connect,
        )
        # A replay has a window of publishes out on purpose: aiomqtt would warn for each one
        # past its default threshold (10).
        client.pending_calls_threshold = REPLAY_WINDOW + 20
        return client

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
        for name, line in self.server.lines.items():
            link = self.links[name] = _BrokerLink(self, line)
            self._spawn(f"{name} pump", link.pump)
            self._spawn(f"{name} connection", link.connect_loop)
            if self.settings.commands:
                for lane_name, lane in link.lanes.items():
                    self._spawn(
                        f"{name} {lane_name}", functools.partial(link.work, lane), link.workers
                    )
                self._spawn(f"{name} answers", link.answer_loop)
            if link.stop_names:
                self._spawn(f"{name} stops connection", link.stop_loop)
        self._spawn("server presence", self._server_presence)
        log.info(
            "mqtt face: %d line(s) to %s:%d",
            len(self.links),
            self.settings.host,
            self.settings.port,
        )

    async def _server_presence(self) -> None:
        online = self.topics.server("online")
        backoff = 0.5
        while True:
            try:
                async with self.client(f"{self.settings.client_id}-server", online) as client:
                    backoff = 0.5
                    await client.publish(online, b"true", qos=1, retain=True)
                    self.presence = client
                    _check_cancelled()  # a stop swallowed by the connect (see connect_loop)
                    async for _ in client.messages:
                        pass
            except aiomqtt.MqttError:
                _check_cancelled()
            await asyncio.sleep(backoff)
            backoff = min(backoff * 2, self.settings.reconnect_max)

    async def stop(self) -> None:
        """Say offline (retained) where connected, then disconnect: a clean stop is not a
        death, but the lines are not served any more either."""
        for link in self.links.values():
            client = link.client
            if client is not None:
                with contextlib.suppress(aiomqtt.MqttError, TimeoutError):
                    await client.publish(
                        self.topics.online(link.line.name),
                        b"false",
                        qos=1,
                        retain=True,
                        timeout=2.0,
                    )
        presence = self.presence
        if presence is not None:
            with contextlib.suppress(aiomqtt.MqttError, TimeoutError):
                await presence.publish(
                    self.topics.server("online"), b"false", qos=1, retain=True, timeout=2.0
                )
        self._stopping = True  # no task is started again from here
        tasks = list(self.tasks)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        self.tasks.clear()
        for link in self.links.values():
            link.buffer.close()


def create(server: LineServer, options: Mapping[str, Any]) -> MqttFace:
    """``options``: the ``[mqtt]`` section (docs/mqtt.md); ``url`` is required."""
    return MqttFace(server, settings_from(options))
