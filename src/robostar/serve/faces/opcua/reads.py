"""OPC UA Read's ``maxAge``: a client that asks for a value no older than it says gets one.

A Read request carries ``maxAge`` (milliseconds): 0 asks for the value as it is now, a larger
one accepts a value that old. Before asyncua answers a client's Read from its nodes, every
variable read that shows a line's value is brought up to date:

- ``maxAge`` 0, or smaller than the age of what the node shows: the line is asked, through its
  queue (``line.read(command, max_age=...)``), and the answer is written into the nodes, with
  its time as the source timestamp; reads of several variables answered by one command (the
  status bits of AA, say) cost one exchange;
- a larger ``maxAge`` that the line server's model meets: the model's sample, unchanged, with
  its own source timestamp and status code (the line is not asked).

If the line cannot answer (it is down, or the read fails), the node is left as it is: its status
code (``BadCommunicationError``, ``UncertainLastUsableValue``) and source timestamp say what it
is, as OPC UA's "best effort" rule has it. Subscriptions are not Reads: they keep publishing the
model as the poller refreshes it, with its timestamps. Reads by the server itself are not
touched.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from asyncua import ua

from robostar.commands.base import Command
from robostar.commands.control import ReadSpeed
from robostar.commands.files import ReadAlarmHistory
from robostar.commands.io import ReadInputs, ReadOutputs
from robostar.commands.job import ReadJobName, ReadJobStep
from robostar.commands.status import ReadAlarms, ReadPosition, ReadStatus
from robostar.commands.variables import ReadGlobalFloat, ReadGlobalInt
from robostar.errors import RobostarError
from robostar.serve.faces.opcua._ua import AttributeIds
from robostar.serve.faces.opcua.address_space import DeviceNodes
from robostar.serve.faces.opcua.publisher import NodeWriter
from robostar.serve.model import Sample
from robostar.types import PositionKind

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["FreshReads", "Source", "sources_of"]

log = logging.getLogger("robostar.serve.opcua")

_STATUS_KEYS = ("ch1/status", "ch2/status", "ch3/status")


@dataclass(frozen=True)
class Source:
    """What a variable shows: the command that reads it and the model keys it answers."""

    command: Command[Any]
    keys: tuple[str, ...]
    in_model: bool = True
    """False for what the line's model does not keep (the global variables): the answer is
    shown as read."""


def sources_of(nodes: DeviceNodes) -> dict[ua.NodeId, Source]:
    """Each variable of a line's nodes that shows a line's value, and its source."""
    found: dict[ua.NodeId, Source] = {}
    for channel, ch in nodes.channels.items():
        angles = Source(ReadPosition(channel, PositionKind.ANGLE), (f"ch{channel}/angles",))
        for node in ch.axes:
            found[node.nodeid] = angles
        by_name = {
            "speed": Source(ReadSpeed(channel), (f"ch{channel}/speed",)),
            "program": Source(ReadJobName(channel), (f"ch{channel}/job",)),
            "step": Source(ReadJobStep(channel), (f"ch{channel}/step",)),
            "cartesian": Source(ReadPosition(channel, PositionKind.XY), (f"ch{channel}/position",)),
        }
        by_name["loaded"] = by_name["program"]
        by_name["arm"] = by_name["cartesian"]
        status = Source(ReadStatus(), _STATUS_KEYS)
        for name in ("in_control", "origin", "in_position", "ready", "running", "alarm"):
            by_name[name] = status
        by_name["current_state"] = by_name["current_state_id"] = status
        for name, source in by_name.items():
            if name in ch.values:
                found[ch.values[name].nodeid] = source
    for key, variable in nodes.values.items():
        line_source = _line_source(key)
        if line_source is not None:
            found[variable.nodeid] = line_source
    return found


def _line_source(key: str) -> Source | None:
    if key in ("alarms", "emergency_stop"):
        return Source(ReadAlarms(), ("alarms",))
    if key == "alarm_history":
        return Source(ReadAlarmHistory(), ("alarm_history",))
    kind, _, index = key.rpartition("/")
    if not index.isdigit():
        return None
    number = int(index)
    command: Command[Any]
    match kind:
        case "io/in":
            return Source(ReadInputs(number), (key,))
        case "io/out":
            return Source(ReadOutputs(number), (key,))
        case "global/int":
            command = ReadGlobalInt(number)
        case "global/float":
            command = ReadGlobalFloat(number)
        case _:
            return None
    return Source(command, (key,), in_model=False)


class FreshReads:
    """asyncua's PreRead callback: brings the variables a client reads up to its maxAge."""

    def __init__(self, publishers: Callable[[str], NodeWriter | None]) -> None:
        self.publishers = publishers
        self.sources: dict[ua.NodeId, tuple[Line, Source]] = {}
        self.line_reads = 0
        """How many reads went to a line (the bench reads it)."""

    def register(self, line: Line, nodes: DeviceNodes) -> None:
        """The variables of ``line`` (again, after its nodes were made again)."""
        self.sources = {n: s for n, s in self.sources.items() if s[0] is not line}
        for node, source in sources_of(nodes).items():
            self.sources[node] = (line, source)

    async def before_read(self, event: Any, dispatcher: Any = None) -> None:
        if not getattr(event, "is_external", False):
            return  # the server's own reads
        params: ua.ReadParameters = event.request_params
        max_age = max(float(params.MaxAge or 0.0), 0.0) / 1000.0
        wanted: dict[tuple[str, Command[Any]], tuple[Line, Source]] = {}
        for item in params.NodesToRead:
            if item.AttributeId != AttributeIds.Value:
                continue
            found = self.sources.get(item.NodeId)
            if found is not None:
                wanted[(found[0].name, found[1].command)] = found
        if wanted:
            await asyncio.gather(
                *(self._bring(line, src, max_age) for line, src in wanted.values())
            )

    async def _bring(self, line: Line, source: Source, max_age: float) -> None:
        publisher = self.publishers(line.name)
        if publisher is None:
            return
        if max_age > 0 and self._young_enough(line, publisher, source, max_age):
            await self._show(line, publisher, source.keys)
            return
        if not line.up:
            return  # best effort: the node says what it is (its status, its time)
        try:
            self.line_reads += 1
            value = await line.read(source.command, max_age=max_age)
        except RobostarError as exc:
            log.debug("opcua %s: %s for a client's read failed: %s", line.name, source, exc)
            return
        if source.in_model:
            await self._show(line, publisher, source.keys)
        else:
            await publisher.apply(source.keys[0], Sample(value, time.time()))

    @staticmethod
    def _young_enough(line: Line, publisher: NodeWriter, source: Source, max_age: float) -> bool:
        now = time.time()
        for key in source.keys:
            sample = line.model.get(key) if source.in_model else publisher.last(key)
            if sample is None:
                if key in _STATUS_KEYS and key != source.keys[0]:
                    continue  # the controller has fewer channels than AA's three
                return False
            if now - sample.at > max_age:  # its quality, whatever it is, goes with it
                return False
        return True

    @staticmethod
    async def _show(line: Line, publisher: NodeWriter, keys: Sequence[str]) -> None:
        """The model's samples of ``keys`` into the nodes, unless they show them already."""
        for key in keys:
            sample = line.model.get(key)
            if sample is not None and publisher.last(key) != sample:
                await publisher.apply(key, sample)
