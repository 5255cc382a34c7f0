"""A condition's state as variables under its node, as SCADA browsers read it with asyncua's
real client: EnabledState, ActiveState, AckedState, ConfirmedState (each with its Id),
ShelvingState/CurrentState (with its Id), Retain, Severity, Comment and ClientUserId are there
by their standard browse names and always say what the condition's last event said. The
standard Enable and Disable methods are refused with BadNotSupported (audited), and the
condition stays enabled."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from asyncua import ua

from robostar.types import Alarm

from .conftest import (
    ACKNOWLEDGE,
    CONFIRM,
    ONE_SHOT_SHELVE,
    RaiseAlarm,
    Setup,
    ack_args,
    audited,
    call,
    text,
)

pytestmark = pytest.mark.timeout(120)


async def read(condition: Any, *path: str) -> Any:
    node = await condition.get_child([f"0:{p}" for p in path])
    return await node.read_value()


async def state_of(condition: Any) -> dict[str, Any]:
    """What a browser shows of a condition: every state variable by its browse path."""
    values: dict[str, Any] = {}
    for name in ("EnabledState", "ActiveState", "AckedState", "ConfirmedState"):
        values[name] = text(await read(condition, name))
        values[f"{name}/Id"] = await read(condition, name, "Id")
    values["Shelving"] = text(await read(condition, "ShelvingState", "CurrentState"))
    values["Shelving/Id"] = await read(condition, "ShelvingState", "CurrentState", "Id")
    for name in ("Retain", "Severity", "ClientUserId"):
        values[name] = await read(condition, name)
    values["Comment"] = text(await read(condition, "Comment"))
    return values


def test_a_condition_s_state_is_readable_and_follows_its_events(
    raised_alarm: RaiseAlarm,
) -> None:
    async def main() -> None:
        async with raised_alarm(Alarm(1005, "air pressure low")) as alarm:
            handler, raised, condition = alarm.events, alarm.raised, alarm.condition
            state = await state_of(condition)
            assert state["EnabledState"] == "Enabled" and state["EnabledState/Id"] is True
            assert state["ActiveState"] == "Active" and state["ActiveState/Id"] is True
            assert state["AckedState"] == "Unacknowledged" and state["AckedState/Id"] is False
            assert state["ConfirmedState/Id"] is False
            assert state["Shelving"] == "Unshelved"
            assert state["Shelving/Id"] == ua.NodeId(ua.ObjectIds.ShelvedStateMachineType_Unshelved)
            assert state["Retain"] is True and state["Severity"] == raised.Severity

            assert (await call(condition, ACKNOWLEDGE, *ack_args(raised, "seen"))).is_good()
            await handler.next_of(1005, 1, "the acknowledgement's event")
            state = await state_of(condition)
            assert state["AckedState"] == "Acknowledged" and state["AckedState/Id"] is True
            assert state["Comment"] == "seen" and state["ClientUserId"] == "olga"

            shelving = await condition.get_child(["0:ShelvingState"])
            assert (await call(shelving, ONE_SHOT_SHELVE)).is_good()
            await handler.next_of(1005, 2, "the shelving's event")
            state = await state_of(condition)
            assert state["Shelving"] == "OneShotShelved"
            assert state["Shelving/Id"] == ua.NodeId(
                ua.ObjectIds.ShelvedStateMachineType_OneShotShelved
            )

            alarm.server.line("cell1").model.set("alarms", ())
            cleared = await handler.next_of(1005, 3, "the clearing's event")
            state = await state_of(condition)
            assert state["ActiveState"] == "Inactive" and state["ActiveState/Id"] is False
            assert state["Shelving"] == "Unshelved"  # a one-shot shelve ends with the alarm
            assert state["Retain"] is True and state["Severity"] == cleared.Severity

            assert (await call(condition, CONFIRM, *ack_args(cleared, "fixed"))).is_good()
            await handler.next_of(1005, 4, "the confirmation's event")
            # of no more interest: the condition and its variables are gone
            with pytest.raises(ua.UaStatusCodeError):
                await read(condition, "ActiveState")

    asyncio.run(main())


def test_enable_and_disable_are_refused_as_not_supported(
    opcua_setup: Setup, raised_alarm: RaiseAlarm
) -> None:
    enable = ua.NodeId(ua.ObjectIds.ConditionType_Enable)
    disable = ua.NodeId(ua.ObjectIds.ConditionType_Disable)

    async def main() -> None:
        async with raised_alarm(Alarm(1007, "vacuum")) as alarm:
            for method in (disable, enable):
                refused = await call(alarm.condition, method)
                assert refused.value == ua.StatusCodes.BadNotSupported
            state = await state_of(alarm.condition)
            assert state["EnabledState/Id"] is True and state["ActiveState/Id"] is True
            assert len(alarm.events.of(1007)) == 1  # nothing changed, so no event
        mine = audited(opcua_setup)
        assert ("olga", "Disable(alarm=1007)", "refused: BadNotSupported") in mine
        assert ("olga", "Enable(alarm=1007)", "refused: BadNotSupported") in mine

    asyncio.run(main())
