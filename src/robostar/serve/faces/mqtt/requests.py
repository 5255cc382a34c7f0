"""A line's commands over MQTT as JSON requests: reading, lanes, running, answering.

Command messages come in on the line's connection (the stops on one of their own, so a flood
of other commands never fills the queue a stop waits in). A reader never waits on the line nor
on the broker: a message goes to its lane (commands, stops), each run one at a time by a worker,
or is refused at once (unknown, not enabled, retained, busy), its answer left to the answer
task. Every refusal is audited; every command runs through the line's lease and audit.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import aiomqtt
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties

from robostar.commands.base import Command
from robostar.errors import RobostarError, UsageError
from robostar.serve.faces.mqtt.commands import (
    ESTOP,
    LEASE_COMMANDS,
    NAMES,
    make_commands,
    read_params,
)
from robostar.serve.faces.mqtt.connection import check_cancelled, command_options, keep_connected
from robostar.serve.faces.mqtt.running import lease_request, resolve_params
from robostar.serve.faces.mqtt.settings import MqttSettings
from robostar.serve.faces.mqtt.topics import Topics, response_topic_problem
from robostar.serve.jsonable import jsonable
from robostar.serve.lease import Who

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["ANSWER_QUEUE", "STOP_NAMES", "BusyError", "CommandRequests", "Lane"]

log = logging.getLogger("robostar.serve.mqtt")

STOP_NAMES = frozenset((ESTOP, "stop_job"))
"""Commands that jump every queue at the line: they have their own lane in the face too."""
ANSWER_QUEUE = 64
"""Refusals the readers made, waiting for their answer to be published (per line). A reader
never waits on an answer's QoS 1 round trip; past this bound an answer is dropped (counted and
logged; the refusal is still audited)."""


def short(text: str, size: int = 80) -> str:
    """A name from the wire, cut to a size fit for a message or the audit log."""
    return text if len(text) <= size else f"{text[:size]}..."


class BusyError(RobostarError):
    """The face already has as many commands waiting or running for a line as it takes."""


@dataclass
class Lane:
    """One line's queue of command messages, run one at a time by a worker task. ``pending``
    counts those waiting or running; the reader refuses more than ``limit``."""

    limit: int
    pending: int = 0
    queue: asyncio.Queue[tuple[aiomqtt.Client, aiomqtt.Message, str]] = field(
        default_factory=asyncio.Queue
    )


class CommandRequests:
    """One line's command lanes, readers, workers and answers."""

    def __init__(
        self,
        line: Line,
        settings: MqttSettings,
        topics: Topics,
        who: Who,
        connect: Callable[[str], aiomqtt.Client],
    ) -> None:
        self.line = line
        self.settings = settings
        self.topics = topics
        self.who = who
        """The name commands run and are audited under (MQTT does not say who sent one)."""
        self._connect = connect
        """A new client by id, with no last will (the stops' connection)."""
        self.lanes = {
            "commands": Lane(settings.max_pending),
            "stops": Lane(settings.max_pending),
        }
        self.workers: list[asyncio.Task[None]] = []
        self.stop_names = STOP_NAMES & settings.commands
        """The enabled stops: they come in on a connection of their own (its own subscription
        and queue), so a flood of other commands never fills the queue a stop waits in."""
        self.stop_client: aiomqtt.Client | None = None
        self.answers: asyncio.Queue[
            tuple[aiomqtt.Client, aiomqtt.Message, str, dict[str, Any], Any]
        ] = asyncio.Queue(maxsize=ANSWER_QUEUE)
        self.answers_dropped = 0
        self._answers_logged = 0.0

    async def stop_loop(self) -> None:
        """The stops' own connection: subscribed to the enabled stops' topics only, so its
        client queue holds stops alone, whatever floods the other command topics."""

        async def serve_stops(client: aiomqtt.Client) -> None:
            for name in sorted(self.stop_names):
                await client.subscribe(
                    self.topics.command(self.line.name, name), options=command_options()
                )
            self.stop_client = client
            check_cancelled()
            await self.read(client, stops=True)

        def lost() -> None:
            self.stop_client = None

        # No last will: this connection's end says nothing about the line.
        client_id = f"{self.settings.client_id}-{self.line.name}-stops"
        await keep_connected(
            f"{self.line.name} (stops)",
            lambda: self._connect(client_id),
            serve_stops,
            lost,
            self.settings.reconnect_max,
        )

    async def read(self, client: aiomqtt.Client, *, stops: bool = False) -> None:
        """Take command messages until the connection fails (MqttError). Nothing here waits on
        the line nor on the broker: a message goes to its lane, or is refused at once (not
        enabled, busy) with its answer left to the answer task."""
        async for message in client.messages:
            name = self.topics.command_name(str(message.topic), self.line.name)
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
            if name not in NAMES:
                problem = UsageError(
                    f"unknown command {short(name)!r} (commands: {', '.join(sorted(NAMES))})"
                )
                self._refuse_later(client, message, name, problem)
                continue
            if name not in self.settings.commands:
                problem = UsageError(f"command {short(name)!r} is not enabled on this server")
                self._refuse_later(client, message, name, problem)
                continue
            lane = self.lanes["stops" if name in STOP_NAMES else "commands"]
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

    async def work(self, lane: Lane) -> None:
        """Run ``lane``'s commands one at a time (the line runs one at a time anyway)."""
        while True:
            client, message, name = await lane.queue.get()
            try:
                await self._command(client, message, name)
            except Exception:  # a handler never dies silently, nor takes its lane with it
                check_cancelled()
                log.exception("mqtt %s: command %s failed", self.line.name, short(name))
            finally:
                lane.pending -= 1

    def _reply_topic(self, message: aiomqtt.Message, name: str) -> tuple[str, str | None]:
        """Where the answer goes, and what is wrong with the request's response topic (then
        the answer goes to the default result topic, and the command is refused)."""
        default = self.topics.result(self.line.name, name)
        requested = getattr(message.properties, "ResponseTopic", None)
        if requested is None:
            return default, None
        problem = response_topic_problem(str(requested), self.topics.prefix)
        if problem is not None:
            return default, f"the response topic {short(str(requested))!r} {problem}"
        return str(requested), None

    def _payload(self, message: aiomqtt.Message) -> bytes:
        raw = message.payload
        payload = raw if isinstance(raw, bytes) else str(raw if raw is not None else "").encode()
        limit = self.settings.max_payload
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
            what = command if command is not None else f"cmd/{short(name)}"
            self.line.record(what, self.who, f"refused: {problem}")
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
            if name in LEASE_COMMANDS:
                answer = lease_request(self.line, self.who, name, params)
                await self._reply(client, message, reply_to, answer, request_id)
                return
            commands = make_commands(name, await resolve_params(self.line, name, params))
            for command in commands:
                command.encode()  # every field's range, as the wire would refuse it
        except RobostarError as exc:
            await self._refuse(client, message, name, exc, command, request_id)
            return
        try:
            result: Any = None
            for command in commands:  # in order; the first refusal ends the sequence
                result = await self.line.execute(command, who=self.who, implicit_lease=True)
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
            check_cancelled()
            log.warning("mqtt %s: no answer sent to %s (%s)", self.line.name, reply_to, exc)
        except Exception:
            log.exception("mqtt %s: no answer sent to %s", self.line.name, reply_to)
