"""A line's model into its OPC UA nodes: values with source time and status, alarms as events.

Each change of the line's model (``ControllerModel``) becomes writes of the variables that show
it, with the time the value was read as the source timestamp and the model's quality as the
status code: ``Good``; ``UncertainLastUsableValue`` when a poll failed and nobody can vouch for
the value; ``BadCommunicationError`` while the line is down. The alarm list goes to the line's
alarm conditions (``conditions.py``), which raise and clear them as OPC UA conditions.
"""

from __future__ import annotations

import datetime as dt
import logging
import time
from collections.abc import Iterable
from dataclasses import replace
from typing import Any

from asyncua import ua
from asyncua.server.server import Server

from robostar.serve.faces.opcua._ua import (
    StatusCodes,
    node_id,
    status,
    timestamp,
)
from robostar.serve.faces.opcua.address_space import ChannelNodes, DeviceNodes
from robostar.serve.faces.opcua.conditions import EMERGENCY_CODES, AlarmConditions, is_emergency
from robostar.serve.model import Quality, Sample
from robostar.types import Alarm, ChannelStatus, Position

__all__ = ["ALARM_EVENT_FIELDS", "EMERGENCY_CODES", "NodeWriter", "is_emergency", "status_of"]

log = logging.getLogger("robostar.serve.opcua")

ALARM_EVENT_FIELDS = (  # besides the condition's own (conditions.py)
    ("AlarmCode", ua.VariantType.Int32),
    ("AlarmText", ua.VariantType.String),
    ("Line", ua.VariantType.String),
    ("Active", ua.VariantType.Boolean),
)
"""The vendor fields of N1AlarmConditionType (an AlarmConditionType)."""

_STATUS = {
    Quality.GOOD: status(StatusCodes.Good),
    Quality.STALE: status(StatusCodes.UncertainLastUsableValue),
    Quality.LINE_DOWN: status(StatusCodes.BadCommunicationError),
}
WAITING = status(StatusCodes.BadWaitingForInitialData)

# TaskControlStateMachineType's states (Robotics nodeset ids)
_STATE_IDS = {"Idle": 5040, "Ready": 5041, "Executing": 5042}


def status_of(quality: Quality) -> ua.StatusCode:
    return _STATUS[quality]


class NodeWriter:
    """Writes one line's model changes into its nodes (see the module docstring)."""

    def __init__(
        self,
        server: Server,
        nodes: DeviceNodes,
        conditions: AlarmConditions,
        robotics_ns: int,
        vendor_ns: int,
    ) -> None:
        self.server = server
        self.nodes = nodes
        self.conditions = conditions
        self.robotics_ns = robotics_ns
        self.vendor_ns = vendor_ns
        self._jobs: dict[int, bool] = {}
        self._running: dict[int, bool] = {}
        self.writes = 0
        self._globals: dict[str, Sample] = {}
        self._shown: dict[str, Sample] = {}

    # -- writing -----------------------------------------------------------------------------
    async def _write(
        self, node: Any, value: Any, variant: ua.VariantType, sample: Sample | None
    ) -> None:
        if sample is None:
            status, at = WAITING, None
        else:
            status = status_of(sample.quality)
            at = timestamp(dt.datetime.fromtimestamp(sample.at, dt.UTC))
        data = ua.DataValue(
            Value=ua.Variant(value, variant),
            StatusCode=status,
            SourceTimestamp=at,
            ServerTimestamp=timestamp(dt.datetime.now(dt.UTC)),
        )
        await self.server.write_attribute_value(node.nodeid, data)
        self.writes += 1

    async def waiting(self) -> None:
        """Every variable the model fills says so until the model has a value."""
        for ch in self.nodes.channels.values():
            for node in ch.axes:
                await self._write(node, 0.0, ua.VariantType.Double, None)
            for name, node in ch.values.items():
                if name != "execution_mode":  # a constant, not the model's
                    variant = await _variant_of(node)
                    await self._write(node, await node.read_value(), variant, None)
        for node in self.nodes.values.values():
            variant = await _variant_of(node)
            await self._write(node, await node.read_value(), variant, None)

    async def show_online(self, up: bool) -> None:
        """Whether the line is up is known to the server even before the model says it."""
        sample = Sample(up, time.time())
        await self._write(self.nodes.values["online"], up, ua.VariantType.Boolean, sample)

    async def apply_all(self, samples: Iterable[tuple[str, Sample]]) -> None:
        for key, sample in samples:
            await self.apply(key, sample)

    async def apply(self, key: str, sample: Sample) -> None:
        """Show one model key's new sample (unknown keys are ignored)."""
        self._shown[key] = sample
        value = sample.value
        nodes = self.nodes
        if key.startswith("ch") and "/" in key:
            head, _, what = key.partition("/")
            channel = nodes.channels.get(int(head[2:])) if head[2:].isdigit() else None
            if channel is not None:
                await self._channel(channel, what, value, sample)
            return
        if key == "online":
            await self._write(nodes.values["online"], bool(value), ua.VariantType.Boolean, sample)
        elif key == "alarms":
            await self._alarm_list(value, sample)
        elif key == "alarm_history":
            texts = [f"{r.code:04d} : {r.text} ({r.detail})".rstrip() for r in value]
            await self._write(nodes.values["alarm_history"], texts, ua.VariantType.String, sample)
        elif key.startswith("global/"):
            node = nodes.values.get(key)
            self._globals[key] = sample
            if node is not None:
                if key.startswith("global/int/"):
                    await self._write(node, int(value), ua.VariantType.Int32, sample)
                else:
                    await self._write(node, float(value), ua.VariantType.Double, sample)
        elif key.startswith("io/"):
            node = nodes.values.get(key)
            if node is not None:
                contacts = list(value.contacts)
                await self._write(node, contacts, ua.VariantType.Boolean, sample)

    def last(self, key: str) -> Sample | None:
        """The sample of ``key`` the nodes show (None: none yet)."""
        return self._shown.get(key)

    async def stale(self, key: str) -> None:
        """A global variable could not be read: its last value stays, marked uncertain."""
        last = self._globals.get(key)
        if last is not None and last.quality is Quality.GOOD:
            await self.apply(key, replace(last, quality=Quality.STALE))

    async def _channel(self, ch: ChannelNodes, what: str, value: Any, sample: Sample) -> None:
        v = ch.values
        if what == "angles" and isinstance(value, Position):
            for node, axis_value in zip(ch.axes, value.axes, strict=False):
                await self._write(node, float(axis_value), ua.VariantType.Double, sample)
        elif what == "position" and isinstance(value, Position):
            await self._write(v["cartesian"], list(value.axes), ua.VariantType.Double, sample)
            await self._write(v["arm"], value.arm.name, ua.VariantType.String, sample)
        elif what == "status" and isinstance(value, ChannelStatus):
            await self._write(v["in_control"], value.servo_on, ua.VariantType.Boolean, sample)
            for name in ("origin", "in_position", "ready", "running", "alarm"):
                flag = bool(getattr(value, name))
                await self._write(v[name], flag, ua.VariantType.Boolean, sample)
            self._running[ch.channel] = value.running
            await self._state(ch, sample)
        elif what == "speed":
            # the N1's speed is 0-1000 (1000 = 100 %); SpeedOverride is a percentage
            await self._write(v["speed"], value / 10.0, ua.VariantType.Double, sample)
        elif what == "job":
            name = str(value) if value is not None else ""
            await self._write(v["program"], name, ua.VariantType.String, sample)
            await self._write(v["loaded"], bool(name), ua.VariantType.Boolean, sample)
            self._jobs[ch.channel] = bool(name)
            await self._state(ch, sample)
        elif what == "step":
            await self._write(v["step"], int(value), ua.VariantType.Int32, sample)

    async def _state(self, ch: ChannelNodes, sample: Sample) -> None:
        """The task control state machine: Executing while running, Ready with a job loaded,
        else Idle."""
        if self._running.get(ch.channel):
            state = "Executing"
        elif self._jobs.get(ch.channel):
            state = "Ready"
        else:
            state = "Idle"
        await self._write(
            ch.values["current_state"],
            ua.LocalizedText(state),
            ua.VariantType.LocalizedText,
            sample,
        )
        await self._write(
            ch.values["current_state_id"],
            node_id(_STATE_IDS[state], self.robotics_ns),
            ua.VariantType.NodeId,
            sample,
        )

    async def _alarm_list(self, alarms: tuple[Alarm, ...], sample: Sample) -> None:
        nodes = self.nodes
        texts = [str(a) for a in alarms]
        await self._write(nodes.values["alarms"], texts, ua.VariantType.String, sample)
        emergency = any(is_emergency(a) for a in alarms)
        await self._write(nodes.values["emergency_stop"], emergency, ua.VariantType.Boolean, sample)
        if sample.quality is not Quality.GOOD:
            return  # a line that went down cleared no alarm
        await self.conditions.update(alarms)


async def _variant_of(node: Any) -> ua.VariantType:
    data = await node.read_data_value()
    variant: ua.VariantType = data.Value.VariantType
    return variant
