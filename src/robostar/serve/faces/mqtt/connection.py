"""The face's MQTT connections: how a client is made, and the one loop that keeps one up.

Every connection of the face (a line's values and commands, a line's stops, the server's
presence, the Sparkplug edge node) is kept by :func:`keep_connected`: connect, run a session on
the connection until it fails, back off (doubling from 0.5 s up to ``reconnect_max``), again.
The helpers here deal with asyncio's ways of losing a cancellation on Python 3.11, so that a
stop always ends these loops.
"""

from __future__ import annotations

import asyncio
import logging
import ssl
import time
from collections.abc import Awaitable, Callable

import aiomqtt
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties
from paho.mqtt.subscribeoptions import SubscribeOptions

from robostar.serve.backoff import Backoff
from robostar.serve.faces.mqtt.settings import MqttSettings

__all__ = [
    "INCOMING_QUEUE",
    "PACKET_OVERHEAD",
    "REPLAY_WINDOW",
    "QueueFullFilter",
    "check_cancelled",
    "client_log",
    "command_options",
    "keep_connected",
    "new_client",
    "wait_event",
]

log = logging.getLogger("robostar.serve.mqtt")

REPLAY_WINDOW = 100
"""Buffered rows a replay has out at once: one round trip per window, not one per row (paho
keeps its own in-flight limit beneath), and a bounded number of publishes waiting."""
PACKET_OVERHEAD = 65_535 + 64
"""What the Maximum Packet Size the face announces allows beyond ``max_payload``: a topic
name's most (65,535 bytes) and a fixed header's and a few properties' worth."""
INCOMING_QUEUE = 256
"""aiomqtt's own queue of received messages per connection. Past it the client discards what
arrives (logged once in a while: QueueFullFilter), so a flood costs bounded memory even before
the face reads it."""


def check_cancelled() -> None:
    """Raise CancelledError if this task was asked to stop. On Python 3.11 a cancellation that
    races with a timeout inside asyncio.wait_for (which aiomqtt's publish uses) comes out as a
    timeout; a loop that handles timeouts must look for it, or a stop would wait forever."""
    task = asyncio.current_task()
    if task is not None and task.cancelling():
        raise asyncio.CancelledError


async def wait_event(event: asyncio.Event, timeout: float | None) -> None:
    """Wait until ``event`` is set or ``timeout`` passes. Not wait_for nor asyncio.timeout: on
    Python 3.11 both can swallow a cancellation that races with the event or the timeout, and
    a stop would then wait forever for this task. asyncio.wait never does. A cancellation an
    earlier await swallowed (a publish's wait_for) is raised here, before waiting."""
    check_cancelled()
    waiter = asyncio.ensure_future(event.wait())
    try:
        await asyncio.wait({waiter}, timeout=timeout)
    finally:
        waiter.cancel()


def command_options() -> SubscribeOptions:
    """How the face subscribes to command topics. A retained command would run again at every
    reconnect and restart: the broker is told not to send retained messages on subscribe
    (retain handling 2), and to keep the retain flag as published (so a retained command that
    arrives live is seen as such, and refused)."""
    return SubscribeOptions(
        qos=1,
        retainAsPublished=True,
        retainHandling=SubscribeOptions.RETAIN_DO_NOT_SEND,
    )


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


def new_client(s: MqttSettings, identifier: str, will: aiomqtt.Will | None) -> aiomqtt.Client:
    """A client of the face's broker as ``identifier``, with ``will`` as its last will."""
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
        will=will,
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


async def keep_connected(
    label: str,
    connect: Callable[[], aiomqtt.Client],
    session: Callable[[aiomqtt.Client], Awaitable[None]],
    lost: Callable[[], None],
    reconnect_max: float,
) -> None:
    """Connect with a client from ``connect()`` and run ``session`` on the connection until it
    fails; then ``lost()`` and again, backing off up to ``reconnect_max`` (reset once a
    connection is made). Runs until cancelled."""
    backoff = Backoff(initial=0.5, factor=2.0, cap=reconnect_max)
    attempt = 0
    while True:
        try:
            async with connect() as client:
                # A stop that raced the connect may have been swallowed (aiomqtt's
                # wait_for on 3.11): look before waiting on this connection for good.
                check_cancelled()
                attempt = 0
                await session(client)
        except (aiomqtt.MqttError, TimeoutError) as exc:  # a replay's publish may time out
            check_cancelled()
            wait = backoff.delay(attempt)
            log.warning("mqtt %s: %s; retrying in %.1f s", label, exc, wait)
        else:
            wait = backoff.delay(attempt)
        finally:
            lost()
        await asyncio.sleep(wait)
        attempt += 1
