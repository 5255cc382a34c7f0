"""A line's N1 alarms as OPC UA alarm conditions (OPC 10000-9: AlarmConditionType).

Each alarm code of a line is one condition, ``ns=urn:robostar:n1;s=<line>.Alarm.<code>``, an
``N1AlarmConditionType`` object (with a ``ShelvingState`` object) referenced from the line's
``MotionDeviceSystem`` by ``HasCondition``. Every change of its state is an event from the
system node carrying the whole state, as SCADA alarm lists expect of a PLC:

- the controller raises it: ``ActiveState`` true, ``AckedState`` and ``ConfirmedState`` false,
  ``Retain`` true;
- an operator acknowledges it (``Acknowledge(EventId, Comment)``, the type's well-known method,
  called on the condition) and then confirms it (``Confirm``); ``Retain`` stays true until the
  alarm is inactive, acknowledged and confirmed; ``AddComment`` adds a comment at any time;
- the controller clears it (a reset, CE, or the cause gone): ``ActiveState`` false;
- shelving (``ShelvingState``'s ``TimedShelve(ms)``, ``OneShotShelve``, ``Unshelve``): a shelved
  condition's events say ``SuppressedOrShelved``, for alarm lists that hide them; a one-shot
  shelve ends when the alarm clears, a timed one when its time is up.

Acknowledging is the operator's word that they have seen the alarm: it sends nothing to the
controller (the N1 has no acknowledgement; its alarms are reset with CE). It needs the operator
role on a signed channel, as the gated methods do, and is audited; it takes no lease, since it
changes nothing on the robot.

asyncua keeps the last event of every retained condition (``Retain`` true) and replays them on
``ConditionRefresh``. The condition nodes exist so that the methods can be called on them
(asyncua refuses a call on an object that is not in the address space), and they carry the
state as variables too, for SCADA browsers that read a condition rather than subscribe to its
events: ``EnabledState``, ``ActiveState``, ``AckedState``, ``ConfirmedState`` (each
``TwoStateVariableType`` with its boolean ``Id``), ``ShelvingState/CurrentState`` (with its
``Id``, the state's node id), ``Retain``, ``Severity``, ``Comment`` and ``ClientUserId``. They
are written before each event is sent, so a client that reads them on an event sees that
event's state.
"""

from __future__ import annotations

import asyncio
import contextlib
import copy
import datetime as dt
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from asyncua import ua
from asyncua.common.node import Node
from asyncua.server.event_generator import EventGenerator
from asyncua.server.server import Server

from robostar.serve.faces.opcua._ua import (
    ObjectIds,
    StatusCodes,
    UaStatusCodeError,
    node_id,
    status,
    timestamp,
)
from robostar.serve.faces.opcua.security import current_caller
from robostar.serve.lease import Who
from robostar.types import Alarm

__all__ = [
    "MAX_TIME_SHELVED",
    "AlarmConditions",
    "ConditionMethods",
    "is_emergency",
]

log = logging.getLogger("robostar.serve.opcua")

EMERGENCY_CODES = frozenset((1153,))
"""Alarm codes that mean an emergency stop (1153 "T/P Emergency", from the manual); an alarm
whose text says "Emergency" counts too, so a controller's own codes are caught."""

MAX_TIME_SHELVED = 8 * 3600 * 1000.0
"""The longest TimedShelve, in milliseconds (a shift): the condition's MaxTimeShelved."""

UNSHELVED, TIMED, ONE_SHOT = "Unshelved", "TimedShelved", "OneShotShelved"
_SHELVING_IDS = {
    UNSHELVED: ObjectIds.ShelvedStateMachineType_Unshelved,
    TIMED: ObjectIds.ShelvedStateMachineType_TimedShelved,
    ONE_SHOT: ObjectIds.ShelvedStateMachineType_OneShotShelved,
}

_EXTRA_FIELDS = (
    ("ShelvingState/CurrentState", ua.VariantType.LocalizedText),
    ("ShelvingState/CurrentState/Id", ua.VariantType.NodeId),
    ("ShelvingState/UnshelveTime", ua.VariantType.Double),
    ("MaxTimeShelved", ua.VariantType.Double),
)
"""Fields asyncua's event object lacks (ShelvingState is an object of the type, not a
variable), or types as a Duration node id it cannot encode: added (or typed) so that clients
selecting them get them."""


def is_emergency(alarm: Alarm) -> bool:
    return alarm.code in EMERGENCY_CODES or "emergency" in alarm.text.lower()


def _code(name: str) -> ua.StatusCode:
    return status(getattr(StatusCodes, name))


_TWO_STATES = (
    ("EnabledState", "Enabled", "Disabled"),
    ("ActiveState", "Active", "Inactive"),
    ("AckedState", "Acknowledged", "Unacknowledged"),
    ("ConfirmedState", "Confirmed", "Unconfirmed"),
)
"""The condition's two-state variables: browse name, and its text when true and false."""

_PLAIN_VARIABLES = (
    ("Retain", ua.VariantType.Boolean, ObjectIds.Boolean),
    ("Severity", ua.VariantType.UInt16, ObjectIds.UInt16),
    ("Comment", ua.VariantType.LocalizedText, ObjectIds.LocalizedText),
    ("ClientUserId", ua.VariantType.String, ObjectIds.String),
)


@dataclass
class _Condition:
    alarm: Alarm
    node: ua.NodeId
    shelving_node: ua.NodeId
    active: bool = True
    acked: bool = False
    confirmed: bool = False
    shelving: str = UNSHELVED
    unshelve_at: float | None = None
    """Monotonic time a timed shelve ends."""
    timer: asyncio.TimerHandle | None = None
    comment: str = ""
    user: str = ""
    event_id: bytes | None = None
    """The last event's EventId: what Acknowledge and Confirm must name."""

    @property
    def retained(self) -> bool:
        return self.active or not self.acked or not self.confirmed

    @property
    def severity(self) -> int:
        return (900 if is_emergency(self.alarm) else 700) if self.active else 100


class AlarmConditions:
    """The conditions of one line (see the module docstring)."""

    def __init__(
        self,
        server: Server,
        line: str,
        vendor_ns: int,
        event_type: ua.NodeId,
        record: Callable[[str, Who, str], None],
    ) -> None:
        self.server = server
        self.line = line
        self.vendor_ns = vendor_ns
        self.event_type = event_type
        self.record = record
        self.conditions: dict[int, _Condition] = {}
        self.events: EventGenerator | None = None
        self._template: Any = None
        self.source: ua.NodeId | None = None
        self.events_sent = 0

    async def attach(self, events: EventGenerator, source: ua.NodeId) -> None:
        """Emit from ``events`` (made for the line's system node ``source``), and point
        ``source`` at every condition (again, after the line's nodes were made again)."""
        template = copy.copy(events.event)
        template.data_types = dict(template.data_types)
        for name, variant in _EXTRA_FIELDS:
            template.add_property(name, None, variant)
        self.events, self._template, self.source = events, template, source
        for condition in self.conditions.values():
            await self._reference(condition.node)

    def owner_of(self, node: ua.NodeId) -> _Condition | None:
        """The condition whose node (or ShelvingState node) ``node`` is."""
        for condition in self.conditions.values():
            if node in (condition.node, condition.shelving_node):
                return condition
        return None

    # -- the controller's side ---------------------------------------------------------------
    async def update(self, alarms: Sequence[Alarm]) -> None:
        """The controller's current alarms: raise the new ones, clear the gone ones."""
        current = {a.code: a for a in alarms}
        for code, alarm in current.items():
            condition = self.conditions.get(code)
            if condition is None:
                condition = await self._make(alarm)
            elif condition.active:
                continue
            else:  # back again before it was confirmed: a new occurrence
                condition.alarm = alarm
                condition.active, condition.acked, condition.confirmed = True, False, False
                condition.comment = condition.user = ""
            await self._emit(condition, f"alarm {alarm}")
        for code, condition in list(self.conditions.items()):
            if code in current or not condition.active:
                continue
            condition.active = False
            if condition.shelving == ONE_SHOT:  # a one-shot shelve lasts while it is active
                self._unshelve(condition)
            await self._emit(condition, f"alarm cleared {condition.alarm}")

    # -- the operator's side -----------------------------------------------------------------
    async def acknowledge(self, condition: _Condition, event_id: Any, comment: Any) -> Any:
        who = self._operator("Acknowledge", condition)
        if isinstance(who, ua.StatusCode):
            return who
        if not self._names_last_event(condition, event_id):
            return self._refuse("Acknowledge", condition, who, "BadEventIdUnknown")
        if condition.acked:
            return self._refuse("Acknowledge", condition, who, "BadConditionBranchAlreadyAcked")
        condition.acked = True
        self._comment(condition, who, comment)
        self.record(self._what("Acknowledge", condition), who, "ok")
        await self._emit(condition, f"acknowledged by {who.name}")
        return []

    async def confirm(self, condition: _Condition, event_id: Any, comment: Any) -> Any:
        who = self._operator("Confirm", condition)
        if isinstance(who, ua.StatusCode):
            return who
        if not self._names_last_event(condition, event_id):
            return self._refuse("Confirm", condition, who, "BadEventIdUnknown")
        if condition.confirmed:
            return self._refuse("Confirm", condition, who, "BadConditionBranchAlreadyConfirmed")
        if not condition.acked:  # confirming comes after acknowledging (OPC 10000-9 5.7.4)
            return self._refuse("Confirm", condition, who, "BadInvalidState")
        condition.confirmed = True
        self._comment(condition, who, comment)
        self.record(self._what("Confirm", condition), who, "ok")
        await self._emit(condition, f"confirmed by {who.name}")
        return []

    async def add_comment(self, condition: _Condition, event_id: Any, comment: Any) -> Any:
        who = self._operator("AddComment", condition)
        if isinstance(who, ua.StatusCode):
            return who
        if not self._names_last_event(condition, event_id):
            return self._refuse("AddComment", condition, who, "BadEventIdUnknown")
        self._comment(condition, who, comment)
        self.record(self._what("AddComment", condition), who, "ok")
        await self._emit(condition, f"comment by {who.name}")
        return []

    async def shelve(self, condition: _Condition, how: str, milliseconds: Any = None) -> Any:
        """``how``: TimedShelved (for ``milliseconds``), OneShotShelved, or Unshelved."""
        verb = {TIMED: "TimedShelve", ONE_SHOT: "OneShotShelve", UNSHELVED: "Unshelve"}[how]
        who = self._operator(verb, condition)
        if isinstance(who, ua.StatusCode):
            return who
        if how == UNSHELVED and condition.shelving == UNSHELVED:
            return self._refuse(verb, condition, who, "BadConditionNotShelved")
        if how != UNSHELVED and condition.shelving == how:
            return self._refuse(verb, condition, who, "BadConditionAlreadyShelved")
        if how == TIMED and (
            isinstance(milliseconds, bool)
            or not isinstance(milliseconds, int | float)
            or not 0 < milliseconds <= MAX_TIME_SHELVED
        ):
            return self._refuse(verb, condition, who, "BadShelvingTimeOutOfRange")
        self._unshelve(condition)
        if how == TIMED:
            assert isinstance(milliseconds, int | float)
            self._shelve_for(condition, milliseconds / 1000.0)
        condition.shelving = how
        self.record(self._what(verb, condition), who, "ok")
        await self._emit(condition, f"{how.lower()} by {who.name}")
        return []

    def not_supported(self, verb: str, condition: _Condition) -> ua.StatusCode:
        """A standard method the face refuses (Enable, Disable), audited as refused."""
        caller = current_caller()
        who = Who(caller.name if caller is not None and caller.name else "anonymous", "opcua")
        return self._refuse(verb, condition, who, "BadNotSupported")

    def close(self) -> None:
        """Stop the timed shelves' timers (the face is stopping)."""
        for condition in self.conditions.values():
            if condition.timer is not None:
                condition.timer.cancel()
                condition.timer = None

    # -- parts -------------------------------------------------------------------------------
    def _operator(self, verb: str, condition: _Condition) -> Who | ua.StatusCode:
        caller = current_caller()
        name = caller.name if caller is not None and caller.name else "anonymous"
        who = Who(name, "opcua")
        if caller is None or not caller.may_operate():
            unsigned = caller is not None and not caller.secure
            why = "an unsigned channel" if unsigned else "not an operator"
            self.record(self._what(verb, condition), who, f"refused: {why}")
            return _code("BadUserAccessDenied")
        return who

    def _refuse(self, verb: str, condition: _Condition, who: Who, code: str) -> ua.StatusCode:
        self.record(self._what(verb, condition), who, f"refused: {code}")
        return _code(code)

    def _what(self, verb: str, condition: _Condition) -> str:
        return f"{verb}(alarm={condition.alarm.code})"

    @staticmethod
    def _names_last_event(condition: _Condition, event_id: Any) -> bool:
        value = event_id.Value if isinstance(event_id, ua.Variant) else event_id
        return condition.event_id is not None and value == condition.event_id

    @staticmethod
    def _comment(condition: _Condition, who: Who, comment: Any) -> None:
        value = comment.Value if isinstance(comment, ua.Variant) else comment
        text = value.Text if isinstance(value, ua.LocalizedText) else value
        condition.comment = str(text or "")
        condition.user = who.name

    def _shelve_for(self, condition: _Condition, seconds: float) -> None:
        loop = asyncio.get_running_loop()
        condition.unshelve_at = time.monotonic() + seconds

        def end() -> None:
            condition.timer = None
            if condition.shelving == TIMED:
                self._unshelve(condition)
                task = loop.create_task(self._emit(condition, "shelving time over"))
                task.add_done_callback(_log_failure)

        condition.timer = loop.call_later(seconds, end)

    @staticmethod
    def _unshelve(condition: _Condition) -> None:
        if condition.timer is not None:
            condition.timer.cancel()
        condition.timer = None
        condition.unshelve_at = None
        condition.shelving = UNSHELVED

    async def _make(self, alarm: Alarm) -> _Condition:
        node = node_id(f"{self.line}.Alarm.{alarm.code}", self.vendor_ns)
        shelving = node_id(f"{self.line}.Alarm.{alarm.code}.ShelvingState", self.vendor_ns)
        condition = _Condition(alarm, node, shelving)
        self.conditions[alarm.code] = condition
        items = [
            _object(
                node, self.source, ObjectIds.HasCondition, f"Alarm{alarm.code}", self.vendor_ns
            ),
            _object(shelving, node, ObjectIds.HasComponent, "ShelvingState", 0),
        ]
        items[0].TypeDefinition = self.event_type
        items[1].TypeDefinition = node_id(ObjectIds.ShelvedStateMachineType)
        items.extend(self._state_variables(condition))
        for result in await self.server.iserver.isession.add_nodes(items):
            if not result.StatusCode.is_good() and result.StatusCode.value != (
                StatusCodes.BadNodeIdExists
            ):
                log.warning("opcua %s: condition node of %s: %s", self.line, alarm, result)
        return condition

    def _state_node(self, condition: _Condition, path: str) -> ua.NodeId:
        return node_id(f"{self.line}.Alarm.{condition.alarm.code}.{path}", self.vendor_ns)

    def _state_variables(self, condition: _Condition) -> list[ua.AddNodesItem]:
        """The condition's state as variables (see the module docstring)."""
        items: list[ua.AddNodesItem] = []
        for name, _, _ in _TWO_STATES:
            state = self._state_node(condition, name)
            items.append(
                _variable(
                    state,
                    condition.node,
                    ObjectIds.HasComponent,
                    name,
                    ObjectIds.LocalizedText,
                    ObjectIds.TwoStateVariableType,
                )
            )
            items.append(
                _variable(
                    self._state_node(condition, f"{name}.Id"),
                    state,
                    ObjectIds.HasProperty,
                    "Id",
                    ObjectIds.Boolean,
                    ObjectIds.PropertyType,
                )
            )
        current = self._state_node(condition, "ShelvingState.CurrentState")
        items.append(
            _variable(
                current,
                condition.shelving_node,
                ObjectIds.HasComponent,
                "CurrentState",
                ObjectIds.LocalizedText,
                ObjectIds.FiniteStateVariableType,
            )
        )
        items.append(
            _variable(
                self._state_node(condition, "ShelvingState.CurrentState.Id"),
                current,
                ObjectIds.HasProperty,
                "Id",
                ObjectIds.NodeId,
                ObjectIds.PropertyType,
            )
        )
        for name, _, data_type in _PLAIN_VARIABLES:
            items.append(
                _variable(
                    self._state_node(condition, name),
                    condition.node,
                    ObjectIds.HasProperty if name == "Retain" else ObjectIds.HasComponent,
                    name,
                    data_type,
                    ObjectIds.PropertyType if name == "Retain" else ObjectIds.BaseDataVariableType,
                )
            )
        return items

    async def _write_state(self, condition: _Condition) -> None:
        """The condition's variables take the state its next event carries."""
        flags = {
            "EnabledState": True,
            "ActiveState": condition.active,
            "AckedState": condition.acked,
            "ConfirmedState": condition.confirmed,
        }
        values: list[tuple[str, Any, ua.VariantType]] = []
        for name, yes, no in _TWO_STATES:
            flag = flags[name]
            values.append(
                (name, ua.LocalizedText(yes if flag else no), ua.VariantType.LocalizedText)
            )
            values.append((f"{name}.Id", flag, ua.VariantType.Boolean))
        values += [
            (
                "ShelvingState.CurrentState",
                ua.LocalizedText(condition.shelving),
                ua.VariantType.LocalizedText,
            ),
            (
                "ShelvingState.CurrentState.Id",
                node_id(_SHELVING_IDS[condition.shelving]),
                ua.VariantType.NodeId,
            ),
            ("Retain", condition.retained, ua.VariantType.Boolean),
            ("Severity", condition.severity, ua.VariantType.UInt16),
            ("Comment", ua.LocalizedText(condition.comment), ua.VariantType.LocalizedText),
            ("ClientUserId", condition.user, ua.VariantType.String),
        ]
        now = timestamp(dt.datetime.now(dt.UTC))
        for path, value, variant in values:
            data = ua.DataValue(
                Value=ua.Variant(value, variant), SourceTimestamp=now, ServerTimestamp=now
            )
            with contextlib.suppress(UaStatusCodeError):
                await self.server.write_attribute_value(self._state_node(condition, path), data)

    async def _reference(self, node: ua.NodeId) -> None:
        if self.source is None:
            return
        source = Node(self.server.iserver.isession, self.source)
        with contextlib.suppress(UaStatusCodeError):
            await source.add_reference(node, node_id(ObjectIds.HasCondition), forward=True)

    async def _emit(self, condition: _Condition, why: str) -> None:
        """One event with the condition's whole state (a fresh event object each time:
        asyncua keeps a retained condition's event object itself)."""
        if self.events is None:
            return
        await self._write_state(condition)
        event = copy.copy(self._template)
        self.events.event = event
        alarm = condition.alarm
        shelved = condition.shelving != UNSHELVED
        remaining = 0.0
        if condition.unshelve_at is not None:
            remaining = max(0.0, (condition.unshelve_at - time.monotonic()) * 1000.0)

        def state(flag: bool, yes: str, no: str) -> ua.LocalizedText:
            return ua.LocalizedText(yes if flag else no)

        fields: dict[str, Any] = {
            "AlarmCode": alarm.code,
            "AlarmText": alarm.text,
            "Line": self.line,
            "Active": condition.active,
            "Severity": condition.severity,
            "SourceName": self.line,
            "NodeId": condition.node,
            "ConditionName": f"{alarm.code:04d}",
            "Retain": condition.retained,
            "ActiveState": state(condition.active, "Active", "Inactive"),
            "ActiveState/Id": condition.active,
            "EnabledState": ua.LocalizedText("Enabled"),
            "EnabledState/Id": True,
            "AckedState": state(condition.acked, "Acknowledged", "Unacknowledged"),
            "AckedState/Id": condition.acked,
            "ConfirmedState": state(condition.confirmed, "Confirmed", "Unconfirmed"),
            "ConfirmedState/Id": condition.confirmed,
            "SuppressedOrShelved": shelved,
            "ShelvingState/CurrentState": ua.LocalizedText(condition.shelving),
            "ShelvingState/CurrentState/Id": node_id(_SHELVING_IDS[condition.shelving]),
            "ShelvingState/UnshelveTime": remaining,
            "MaxTimeShelved": MAX_TIME_SHELVED,
            "Comment": ua.LocalizedText(condition.comment),
            "ClientUserId": condition.user,
            "Quality": status(StatusCodes.Good),
        }
        for name, value in fields.items():
            if name in event.data_types:
                setattr(event, name, value)
        await self.events.trigger(message=f"{self.line}: {why}")
        event_id = event.EventId
        condition.event_id = event_id.Value if isinstance(event_id, ua.Variant) else event_id
        self.events_sent += 1
        if not condition.retained:
            await self._forget(condition)

    async def _forget(self, condition: _Condition) -> None:
        """A condition of no more interest (inactive, acknowledged, confirmed): its nodes go
        (without asyncua's scan of the whole space for references: the source's one is
        removed by hand)."""
        self.conditions.pop(condition.alarm.code, None)
        isession = self.server.iserver.isession
        if self.source is not None:
            with contextlib.suppress(UaStatusCodeError):
                await Node(isession, self.source).delete_reference(
                    condition.node,
                    node_id(ObjectIds.HasCondition),
                    forward=True,
                    bidirectional=False,
                )
        with contextlib.suppress(UaStatusCodeError):
            await Node(isession, condition.node).delete(delete_references=False, recursive=True)


def _object(
    node: ua.NodeId, parent: ua.NodeId | None, reference: int, name: str, namespace: int
) -> ua.AddNodesItem:
    """An object node without its type's children (the state lives in the events); the
    caller sets its TypeDefinition."""
    item = ua.AddNodesItem()
    item.RequestedNewNodeId = node
    item.BrowseName = ua.QualifiedName(name, namespace)
    item.NodeClass = ua.NodeClass.Object
    item.ParentNodeId = parent if parent is not None else ua.NodeId()
    item.ReferenceTypeId = node_id(reference)
    attributes = ua.ObjectAttributes()
    attributes.DisplayName = ua.LocalizedText(name)
    attributes.EventNotifier = 0
    item.NodeAttributes = attributes
    return item


def _variable(
    node: ua.NodeId,
    parent: ua.NodeId,
    reference: int,
    name: str,
    data_type: int,
    type_definition: int,
) -> ua.AddNodesItem:
    """A read-only variable of a condition's state (the standard browse names, namespace 0)."""
    item = ua.AddNodesItem()
    item.RequestedNewNodeId = node
    item.BrowseName = ua.QualifiedName(name, 0)
    item.NodeClass = ua.NodeClass.Variable
    item.ParentNodeId = parent
    item.ReferenceTypeId = node_id(reference)
    item.TypeDefinition = node_id(type_definition)
    attributes = ua.VariableAttributes()
    attributes.DisplayName = ua.LocalizedText(name)
    attributes.DataType = node_id(data_type)
    attributes.ValueRank = -1
    attributes.AccessLevel = ua.AccessLevel.CurrentRead.mask
    attributes.UserAccessLevel = ua.AccessLevel.CurrentRead.mask
    item.NodeAttributes = attributes
    return item


def _log_failure(task: asyncio.Task[Any]) -> None:
    if not task.cancelled() and task.exception() is not None:
        log.error("opcua: a condition's event failed", exc_info=task.exception())


class ConditionMethods:
    """The well-known condition methods (Acknowledge, Confirm, the shelving ones) for every
    line: asyncua binds one handler per method node, so calls are routed by the condition
    (or ShelvingState) node they are made on."""

    def __init__(self) -> None:
        self.lines: list[AlarmConditions] = []

    def bind(self, server: Server) -> None:
        o = ObjectIds
        # the shelving methods by the state machine type's ids and by AlarmConditionType's
        # instance declarations: clients use either
        table: list[tuple[tuple[int, ...], Callable[..., Any]]] = [
            ((o.AcknowledgeableConditionType_Acknowledge,), self._acknowledge),
            ((o.AcknowledgeableConditionType_Confirm,), self._confirm),
            ((o.ConditionType_AddComment,), self._add_comment),
            ((o.ConditionType_Enable,), self._enable),
            ((o.ConditionType_Disable,), self._disable),
            (
                (
                    o.ShelvedStateMachineType_TimedShelve,
                    o.AlarmConditionType_ShelvingState_TimedShelve,
                ),
                self._timed,
            ),
            (
                (
                    o.ShelvedStateMachineType_OneShotShelve,
                    o.AlarmConditionType_ShelvingState_OneShotShelve,
                ),
                self._one_shot,
            ),
            (
                (o.ShelvedStateMachineType_Unshelve, o.AlarmConditionType_ShelvingState_Unshelve),
                self._unshelve,
            ),
        ]
        for ids, handler in table:
            for identifier in ids:
                server.link_method(server.get_node(node_id(identifier)), handler)

    def _find(self, node: ua.NodeId) -> tuple[AlarmConditions, _Condition] | None:
        for line in self.lines:
            condition = line.owner_of(node)
            if condition is not None:
                return line, condition
        return None

    async def _acknowledge(self, parent: ua.NodeId, *args: Any) -> Any:
        found = self._find(parent)
        if found is None or len(args) != 2:
            return _code("BadNodeIdUnknown" if found is None else "BadArgumentsMissing")
        return await found[0].acknowledge(found[1], *args)

    async def _confirm(self, parent: ua.NodeId, *args: Any) -> Any:
        found = self._find(parent)
        if found is None or len(args) != 2:
            return _code("BadNodeIdUnknown" if found is None else "BadArgumentsMissing")
        return await found[0].confirm(found[1], *args)

    async def _add_comment(self, parent: ua.NodeId, *args: Any) -> Any:
        found = self._find(parent)
        if found is None or len(args) != 2:
            return _code("BadNodeIdUnknown" if found is None else "BadArgumentsMissing")
        return await found[0].add_comment(found[1], *args)

    async def _enable(self, parent: ua.NodeId, *args: Any) -> Any:
        return self._not_supported("Enable", parent)

    async def _disable(self, parent: ua.NodeId, *args: Any) -> Any:
        return self._not_supported("Disable", parent)

    def _not_supported(self, verb: str, parent: ua.NodeId) -> ua.StatusCode:
        """Enable and Disable are refused: an N1 alarm cannot be switched off at the
        controller, and a disabled condition would hide a live alarm from every alarm list
        (shelving hides it from the lists that want that, for a bounded time)."""
        found = self._find(parent)
        if found is None:
            return _code("BadNodeIdUnknown")
        return found[0].not_supported(verb, found[1])

    async def _timed(self, parent: ua.NodeId, *args: Any) -> Any:
        found = self._find(parent)
        if found is None or len(args) != 1:
            return _code("BadNodeIdUnknown" if found is None else "BadArgumentsMissing")
        value = args[0].Value if isinstance(args[0], ua.Variant) else args[0]
        return await found[0].shelve(found[1], TIMED, value)

    async def _one_shot(self, parent: ua.NodeId, *args: Any) -> Any:
        found = self._find(parent)
        if found is None:
            return _code("BadNodeIdUnknown")
        return await found[0].shelve(found[1], ONE_SHOT)

    async def _unshelve(self, parent: ua.NodeId, *args: Any) -> Any:
        found = self._find(parent)
        if found is None:
            return _code("BadNodeIdUnknown")
        return await found[0].shelve(found[1], UNSHELVED)
