"""The Sparkplug B edge node: the line server on one MQTT connection, each line a device.

At each connection: a new bdSeq in the NDEATH set as the last will; when a primary host
application is configured, wait for its STATE to say online; then NBIRTH, and a DBIRTH for each
line that is up. Each line's pump reports its model's changes by exception (the JSON tree's
reporter: deadband, rate cap) as DDATA by alias; a line going down is a DDEATH, coming back a
DBIRTH. An NCMD ``Node Control/Rebirth`` births everything again. DCMD metrics ``cmd/<name>``
(JSON parameters as text, as on the JSON tree), and writes of the setpoints' own metrics
(``ch1/speed``, ``io/out/0/3``: see :mod:`.setpoints`), run commands when the face's commands are
enabled, through the same allowlist, lease and audit; the outcome is the DDATA metric
``cmd/<name>/result``. Births and data go out at QoS 0, as the specification asks.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import time
from collections import deque
from typing import TYPE_CHECKING, Any

import aiomqtt
from google.protobuf.message import DecodeError

from robostar.errors import RobostarError, UsageError
from robostar.serve.faces.mqtt.commands import LEASE_COMMANDS, read_params
from robostar.serve.faces.mqtt.connection import (
    check_cancelled,
    keep_connected,
    new_client,
    wait_event,
)
from robostar.serve.faces.mqtt.control import CONTROL_KEY, control_sample, watch_control
from robostar.serve.faces.mqtt.leaves import channel_of, leaves, robot_of
from robostar.serve.faces.mqtt.reporter import Reporter
from robostar.serve.faces.mqtt.requests import STOP_NAMES
from robostar.serve.faces.mqtt.running import lease_request, prepare_commands
from robostar.serve.faces.mqtt.settings import MqttSettings, SparkplugSettings
from robostar.serve.faces.mqtt.sparkplug.session import (
    REBIRTH,
    Metric,
    NeedsBirth,
    NodeSession,
    SparkplugTopics,
    decode,
)
from robostar.serve.faces.mqtt.sparkplug.setpoints import SETPOINTS, setpoint_command
from robostar.serve.jsonable import jsonable
from robostar.serve.lease import Who
from robostar.serve.model import Sample

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["SparkplugNode", "line_metrics"]

log = logging.getLogger("robostar.serve.mqtt.sparkplug")

_UNBORN_RETRY = 0.25
"""How often a pump looks whether its line, not born yet, can be born (seconds)."""
_NOT_METRICS = frozenset(("online",))
"""Model keys that are no metric: a device's birth and death say whether its line is up."""


def line_metrics(line: Line, key: str, sample: Sample) -> list[Metric]:
    """One model value as the device's metrics (``ch1/status/servo_on``, ``ch1/position/x``)."""
    if key in _NOT_METRICS:
        return []
    channel = channel_of(key)
    if channel is not None and channel not in line.channels():
        return []  # a channel the controller does not have
    robot = robot_of(line.info, key)
    return [
        Metric(
            f"{key}/{leaf.name}" if leaf.name else key,
            leaf.value,
            sample.at,
            leaf.unit,
            sample.quality,
        )
        for leaf in leaves(sample.value, robot)
    ]


class _Device:
    """One line as a device: its reporter, and its commands waiting to run."""

    def __init__(self, line: Line, settings: MqttSettings) -> None:
        self.line = line
        self.reporter = Reporter(deadband=settings.deadband, max_rate=settings.rate)
        self.wake = asyncio.Event()
        self.commands: asyncio.Queue[tuple[str, bytes]] = asyncio.Queue(settings.max_pending)
        self.stops: asyncio.Queue[tuple[str, bytes]] = asyncio.Queue(settings.max_pending)
        self.history: deque[Metric] = deque(maxlen=settings.buffer_rows)
        """Changes while the broker was away (the oldest go first past ``buffer_rows``)."""
        """The stops' own lane (``estop``, ``stop_job``): never behind another command."""


class SparkplugNode:
    """The edge node of ``lines`` (see the module's docstring)."""

    def __init__(
        self,
        lines: dict[str, Line],
        settings: MqttSettings,
        sparkplug: SparkplugSettings,
        who: Who,
    ) -> None:
        self.settings = settings
        self.sparkplug = sparkplug
        self.who = who
        self.topics = SparkplugTopics(sparkplug.group, sparkplug.node)
        self.session = NodeSession(self.topics)
        self.devices = {name: _Device(line, settings) for name, line in lines.items()}
        self.client: aiomqtt.Client | None = None
        """The connection, once the node is born on it (None: births and data wait)."""
        self.births = 0
        self.published = 0
        self.connected = False
        """An MQTT connection is up (the node may still wait for its host, or be born)."""
        self.death = b""
        """The NDEATH of the current connection (its last will; said by a clean stop too)."""

    # -- the connection ----------------------------------------------------------------------
    def _connect(self) -> aiomqtt.Client:
        self.death = self.session.next_connection()
        will = aiomqtt.Will(self.topics.of_node("NDEATH"), self.death, qos=1, retain=False)
        return new_client(self.settings, f"{self.settings.client_id}-sparkplug", will)

    def _lost(self) -> None:
        self.client = None
        self.connected = False

    async def say_death(self) -> None:
        """A clean stop: the NDEATH the will would have said (a clean disconnect sends none)."""
        client = self.client
        if client is not None:
            self.client = None
            with contextlib.suppress(aiomqtt.MqttError, TimeoutError):
                await client.publish(self.topics.of_node("NDEATH"), self.death, qos=1, timeout=2.0)

    async def run(self) -> None:
        """Keep the node connected and born, for as long as the face runs."""
        await keep_connected(
            f"sparkplug {self.sparkplug.node}",
            self._connect,
            self._serve,
            self._lost,
            self.settings.reconnect_max,
        )

    async def _serve(self, client: aiomqtt.Client) -> None:
        self.connected = True
        host = self.sparkplug.primary_host
        if host is not None:
            await client.subscribe(SparkplugTopics.state(host), qos=1)
            async for message in client.messages:
                if _host_online(message) is True:
                    break
            check_cancelled()
        await client.subscribe(self.topics.of_node("NCMD"), qos=1)
        if self.settings.commands:
            await client.subscribe(self.topics.device_commands(), qos=1)
        await self._birth(client)
        async for message in client.messages:
            topic = str(message.topic)
            if host is not None and topic == SparkplugTopics.state(host):
                if _host_online(message) is False:
                    # The specification: an edge node whose primary host went away ends its
                    # session (a clean disconnect: the death said, as the will is not), and is
                    # born again once the host is back.
                    await self.say_death()
                    raise aiomqtt.MqttError(f"the primary host {host} is offline")
            elif topic == self.topics.of_node("NCMD"):
                if _asks_rebirth(message):
                    log.info("sparkplug: rebirth asked by a host application")
                    await self._birth(client)
            else:
                self._take_command(topic, message)
        raise aiomqtt.MqttError("the broker closed the connection")

    async def _birth(self, client: aiomqtt.Client) -> None:
        """NBIRTH, then a DBIRTH for each line that is up; data goes out on ``client`` after."""
        self.client = None
        await client.publish(self.topics.of_node("NBIRTH"), self.session.node_birth(), qos=0)
        self.births += 1
        for name, device in self.devices.items():
            if _ready(device.line):
                await self._device_birth(client, name, device)
        self.client = client
        for device in self.devices.values():
            device.wake.set()

    async def _device_birth(self, client: aiomqtt.Client, name: str, device: _Device) -> None:
        metrics: list[Metric] = []
        snapshot = device.line.model.snapshot()
        for key, sample in snapshot.items():
            metrics += line_metrics(device.line, key, sample)
        # who holds the line's control: declared here, its changes by exception as any value
        control = control_sample(device.line)
        metrics += line_metrics(device.line, CONTROL_KEY, control)
        device.reporter.mark_sent(CONTROL_KEY, control)
        now = time.time()
        for command in sorted(self.settings.commands):
            metrics.append(Metric(f"cmd/{command}", "", now))
            metrics.append(Metric(f"cmd/{command}/result", "", now))
        await client.publish(
            self.topics.of_device("DBIRTH", name), self.session.device_birth(name, metrics), qos=0
        )
        self.births += 1
        while device.history:  # what waited, in order, after the birth gave the current state
            batch = [device.history.popleft() for _ in range(min(500, len(device.history)))]
            payload = self.session.historical_data(name, batch)
            if payload is not None:
                await self._publish(client, self.topics.of_device("DDATA", name), payload)

    # -- the data ----------------------------------------------------------------------------
    async def pump(self, name: str) -> None:
        """One line's changes as DDATA (DDEATH and DBIRTH as its line goes and comes)."""
        device = self.devices[name]
        with device.line.model.subscribe(maxsize=10_000) as changes:
            feeder = asyncio.create_task(self._feed(device, changes))
            watcher = asyncio.create_task(watch_control(device.line, device.reporter, device.wake))
            try:
                while True:
                    check_cancelled()
                    await self._send_due(name, device)
                    device.wake.clear()
                    due = device.reporter.next_due(time.monotonic())
                    timeout = None if due is None else max(0.0, due - time.monotonic())
                    if self.client is not None and name not in self.session.born:
                        # Up but not polled through yet, or down: look again soon (a first
                        # poll that changes nothing more wakes no one).
                        timeout = min(timeout, _UNBORN_RETRY) if timeout else _UNBORN_RETRY
                    await wait_event(device.wake, timeout)
            finally:
                feeder.cancel()
                watcher.cancel()

    async def _feed(self, device: _Device, changes: Any) -> None:
        async for change in changes:
            device.reporter.offer(change.key, change.sample)
            device.wake.set()

    async def _send_due(self, name: str, device: _Device) -> None:
        client = self.client
        line = device.line
        if client is None:
            if self.connected:
                return  # being born: the changes wait in the reporter, then go out as DDATA
            # Store and forward: once the node has been born, what changes while the broker is
            # away is kept, and sent as historical after the next birth (the current state).
            due = device.reporter.due(time.monotonic())
            if self.births and line.up:
                for key, sample in due:
                    device.history.extend(line_metrics(line, key, sample))
            return
        born = name in self.session.born
        if not line.up:
            if born:
                payload = self.session.device_death(name)
                await self._publish(client, self.topics.of_device("DDEATH", name), payload)
            device.reporter.due(time.monotonic())  # the birth will say it all again
            return
        if not born:
            if _ready(line):
                await self._device_birth(client, name, device)
            return
        metrics: list[Metric] = []
        for key, sample in device.reporter.due(time.monotonic()):
            metrics += line_metrics(line, key, sample)
        try:
            payload_or_none = self.session.device_data(name, metrics)
        except NeedsBirth as why:
            log.info("sparkplug %s: born again (%s)", name, why)
            await self._device_birth(client, name, device)
            return
        if payload_or_none is not None:
            await self._publish(client, self.topics.of_device("DDATA", name), payload_or_none)

    async def _publish(self, client: aiomqtt.Client, topic: str, payload: bytes) -> None:
        try:
            await client.publish(topic, payload, qos=0)
            self.published += 1
        except aiomqtt.MqttError as exc:  # the connection's loop makes a new session
            check_cancelled()
            log.warning("sparkplug: publish on %s failed (%s)", topic, exc)

    # -- commands ----------------------------------------------------------------------------
    def _take_command(self, topic: str, message: aiomqtt.Message) -> None:
        name = topic.rsplit("/", 1)[-1]
        device = self.devices.get(name)
        if device is None:
            return
        raw = message.payload
        try:
            payload = decode(raw if isinstance(raw, bytes) else b"")
        except DecodeError:
            device.line.record("DCMD", self.who, "refused: not a Sparkplug B payload")
            return
        for metric in payload.metrics:
            metric_name = metric.name or self.session.name_of(name, metric.alias) or ""
            if metric_name.startswith("cmd/") and not metric_name.endswith("/result"):
                command = metric_name[4:]
                text = metric.string_value.encode() if metric.HasField("string_value") else b""
            else:
                # a write of a setpoint's own metric (ch1/speed): its command, same rules
                try:
                    setpoint = setpoint_command(metric_name, metric)
                except UsageError as exc:
                    device.line.record(f"DCMD {metric_name[:80]}", self.who, f"refused: {exc}")
                    continue
                if setpoint is None:
                    shapes = ", ".join(("cmd/<name>", *SETPOINTS))
                    device.line.record(
                        f"DCMD {metric_name[:80]}",
                        self.who,
                        f"refused: not a command metric nor a writable setpoint ({shapes})",
                    )
                    continue
                command, params = setpoint
                text = json.dumps(params).encode()
            try:
                lane = device.stops if command in STOP_NAMES else device.commands
                lane.put_nowait((command, text))
            except asyncio.QueueFull:
                device.line.record(f"cmd/{command[:80]}", self.who, "refused: busy")

    async def work(self, name: str, stops: bool = False) -> None:
        """Run one device's commands (or its stops) one at a time; each outcome is a
        ``.../result`` DDATA."""
        device = self.devices[name]
        lane = device.stops if stops else device.commands
        while True:
            command_name, text = await lane.get()
            body = await self._run(device.line, command_name, text)
            client = self.client
            if client is None or name not in self.session.born:
                continue
            result = Metric(f"cmd/{command_name}/result", json.dumps(body), time.time())
            try:
                payload = self.session.device_data(name, [result])
            except NeedsBirth:
                continue  # a command the birth did not declare: refused and audited above
            if payload is not None:
                await self._publish(client, self.topics.of_device("DDATA", name), payload)

    async def _run(self, line: Line, name: str, text: bytes) -> dict[str, Any]:
        try:
            if name not in self.settings.commands:
                raise UsageError(f"command {name[:80]!r} is not enabled on this server")
            params = read_params(text)
            if name in LEASE_COMMANDS:
                return lease_request(line, self.who, name, params)
            commands = await prepare_commands(line, name, params)
        except RobostarError as exc:
            line.record(f"cmd/{name[:80]}", self.who, f"refused: {exc}")
            return {"ok": False, "error": str(exc), "kind": type(exc).__name__}
        try:
            result: Any = None
            for command in commands:  # in order; the first refusal ends the sequence
                result = await line.execute(command, who=self.who, implicit_lease=True)
        except RobostarError as exc:  # execute audited it
            return {"ok": False, "error": str(exc), "kind": type(exc).__name__}
        return {"ok": True, "result": jsonable(result)}


def _ready(line: Line) -> bool:
    """Whether a line can be born: up, and polled through once (so its birth declares every
    metric, rather than each new one costing a rebirth as the first poll fills the model)."""
    return line.up and line.health.last_poll is not None


def _host_online(message: aiomqtt.Message) -> bool | None:
    """A STATE message's ``online`` (Sparkplug 3.0 JSON), or None when it says nothing."""
    raw = message.payload
    try:
        state = json.loads(raw if isinstance(raw, bytes | str) else b"")
    except ValueError:
        return None
    online = state.get("online") if isinstance(state, dict) else None
    return online if isinstance(online, bool) else None


def _asks_rebirth(message: aiomqtt.Message) -> bool:
    raw = message.payload
    try:
        payload = decode(raw if isinstance(raw, bytes) else b"")
    except DecodeError:
        return False
    return any(m.name == REBIRTH and m.boolean_value for m in payload.metrics)
