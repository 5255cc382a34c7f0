"""A line's control lease as OPC UA nodes: who holds it, and TakeControl / ReleaseControl.

Under each line's ``MotionDeviceSystem`` (vendor namespace)::

    Control                         object ``ns=urn:robostar:n1;s=<line>.Control``
      Free          Boolean         nobody holds the lease
      Holder        String          the holder's name ("" when free)
      Face          String          the face it came through (opcua, api, n1, web, ...)
      Until         DateTime        when it runs out unless renewed (when free: OPC UA's null
                                    DateTime, 1601-01-01)
      SecondsLeft   Double          seconds from the read to Until (0 when free)
      OneShot       Boolean         held for one command only (a face's single write)
      TakeControl(Seconds Double)   take the free lease (or renew one's own) for Seconds, 0 for
                                    the line's idle time; output Until (DateTime)
      ReleaseControl()              give it back (its holder only)

The values are the lease at the instant asked: a client's Read brings them up to date before
it is answered (``SecondsLeft`` counts from that read), and subscribers get them as the face's
refresher writes them (every :data:`REFRESH_SECONDS`, and right after a take or release
through this face).

The methods need the operator role on a signed channel (else ``BadUserAccessDenied``) and go
through ``line.take_control`` / ``line.release_control``, which audit every take, renewal,
release and refusal. A lease held by another: ``BadLocked``; ``Seconds`` not a finite number
in [0, max(3600, the line's lease time)]: ``BadInvalidArgument``; ReleaseControl by someone
who does not hold it: ``BadInvalidState`` (nothing released, audited).
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from asyncua import ua
from asyncua.common.node import Node
from asyncua.server.server import Server

from robostar.serve.faces.opcua._ua import AttributeIds, StatusCodes, node_id, status, timestamp
from robostar.serve.faces.opcua.security import current_caller
from robostar.serve.lease import LeaseHeldError, LeaseState, Who

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["MAX_TAKE_SECONDS", "REFRESH_SECONDS", "ControlNodes", "build_control"]

MAX_TAKE_SECONDS = 3600.0
"""The longest TakeControl (or the line's lease time, if longer), as the API's lease."""

REFRESH_SECONDS = 1.0
"""How often subscribers' values are written (SecondsLeft changes all the time)."""


NULL_DATETIME = timestamp(dt.datetime(1601, 1, 1, tzinfo=dt.UTC))
"""OPC UA's null DateTime (the binary encoding's 0): Until when nobody holds the lease."""


def _code(name: str) -> ua.StatusCode:
    return status(getattr(StatusCodes, name))


@dataclass
class ControlNodes:
    """One line's Control object and its variables."""

    server: Server
    line: Line
    node: Node
    values: dict[str, Node]
    take: Node
    release: Node

    @property
    def node_ids(self) -> set[ua.NodeId]:
        return {n.nodeid for n in self.values.values()}

    async def show(self) -> None:
        """Write the lease as it is now."""
        await self._write(self.line.control())

    async def _write(self, state: LeaseState) -> None:
        now = timestamp(dt.datetime.now(dt.UTC))
        until = NULL_DATETIME
        if state.until is not None:
            until = timestamp(dt.datetime.fromtimestamp(state.until, dt.UTC))
        values: dict[str, ua.Variant] = {
            "Free": ua.Variant(state.free, ua.VariantType.Boolean),
            "Holder": ua.Variant(state.holder or "", ua.VariantType.String),
            "Face": ua.Variant(state.face or "", ua.VariantType.String),
            "Until": ua.Variant(until, ua.VariantType.DateTime),
            "SecondsLeft": ua.Variant(state.left or 0.0, ua.VariantType.Double),
            "OneShot": ua.Variant(state.once, ua.VariantType.Boolean),
        }
        for name, variant in values.items():
            data = ua.DataValue(Value=variant, SourceTimestamp=now, ServerTimestamp=now)
            await self.server.write_attribute_value(self.values[name].nodeid, data)

    # -- the methods -----------------------------------------------------------------------
    async def take_control(self, parent: ua.NodeId, *args: Any) -> Any:
        who = self._operator("lease take")
        if isinstance(who, ua.StatusCode):
            return who
        values = [a.Value if isinstance(a, ua.Variant) else a for a in args]
        longest = max(MAX_TAKE_SECONDS, self.line.lease.ttl)
        seconds = values[0] if len(values) == 1 else None
        if (
            isinstance(seconds, bool)
            or not isinstance(seconds, int | float)
            or not math.isfinite(seconds)
            or not 0 <= seconds <= longest
        ):
            self.line.record(
                "lease take", who, f"refused: Seconds {seconds!r} not in [0, {longest:g}]"
            )
            return _code("BadInvalidArgument")
        try:
            info = self.line.take_control(who, float(seconds) or None)
        except LeaseHeldError:  # audited by take_control
            return _code("BadLocked")
        await self.show()
        until = timestamp(dt.datetime.fromtimestamp(info.expires_at, dt.UTC))
        return [ua.Variant(until, ua.VariantType.DateTime)]

    async def release_control(self, parent: ua.NodeId, *args: Any) -> Any:
        who = self._operator("lease release")
        if isinstance(who, ua.StatusCode):
            return who
        released = self.line.release_control(who)  # audited
        await self.show()
        return [] if released else _code("BadInvalidState")

    def _operator(self, what: str) -> Who | ua.StatusCode:
        caller = current_caller()
        who = Who(caller.name if caller is not None and caller.name else "anonymous", "opcua")
        if caller is None or not caller.may_operate():
            unsigned = caller is not None and not caller.secure
            why = "an unsigned channel" if unsigned else "not an operator"
            self.line.record(what, who, f"refused: {why}")
            return _code("BadUserAccessDenied")
        return who


async def build_control(server: Server, vendor_ns: int, line: Line, system: Node) -> ControlNodes:
    """Make the line's Control object under its system node, methods bound."""
    prefix = f"{line.name}.Control"

    def name(text: str) -> ua.QualifiedName:
        return ua.QualifiedName(text, vendor_ns)

    control = await system.add_object(node_id(prefix, vendor_ns), name("Control"))
    specs: tuple[tuple[str, Any, ua.VariantType, str], ...] = (
        ("Free", True, ua.VariantType.Boolean, "Nobody holds the line's control lease."),
        ("Holder", "", ua.VariantType.String, "Who holds the lease (empty when free)."),
        ("Face", "", ua.VariantType.String, "The face the holder came through."),
        (
            "Until",
            NULL_DATETIME,
            ua.VariantType.DateTime,
            "When the lease runs out unless renewed.",
        ),
        ("SecondsLeft", 0.0, ua.VariantType.Double, "Seconds from the read to Until."),
        ("OneShot", False, ua.VariantType.Boolean, "Held for one command only."),
    )
    values: dict[str, Node] = {}
    for text, value, variant, about in specs:
        node = await control.add_variable(
            node_id(f"{prefix}.{text}", vendor_ns), name(text), ua.Variant(value, variant)
        )
        await node.write_attribute(
            AttributeIds.Description, ua.DataValue(ua.Variant(ua.LocalizedText(about)))
        )
        values[text] = node
    nodes = ControlNodes(server, line, control, values, control, control)
    seconds = ua.Argument()
    seconds.Name = "Seconds"
    seconds.DataType = node_id(ua.VariantType.Double.value)
    seconds.ValueRank = -1
    seconds.Description = ua.LocalizedText("How long to hold it; 0: the line's lease time.")
    until = ua.Argument()
    until.Name = "Until"
    until.DataType = node_id(ua.VariantType.DateTime.value)
    until.ValueRank = -1
    until.Description = ua.LocalizedText("When the lease runs out unless renewed.")
    nodes.take = await control.add_method(
        node_id(f"{prefix}.TakeControl", vendor_ns),
        name("TakeControl"),
        nodes.take_control,
        [seconds],
        [until],
    )
    nodes.release = await control.add_method(
        node_id(f"{prefix}.ReleaseControl", vendor_ns),
        name("ReleaseControl"),
        nodes.release_control,
        [],
        [],
    )
    await nodes.show()
    return nodes
