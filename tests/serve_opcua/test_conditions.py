"""The N1's alarms as OPC UA alarm conditions, as a SCADA alarm list uses them with asyncua's
real client: an alarm raises an unacknowledged, unconfirmed condition; operators (only) acknowledge
and confirm it on the condition, naming its last event; it stays retained (and is replayed by
ConditionRefresh) until it is inactive, acknowledged and confirmed; shelving hides it from alarm
lists for a time or until it clears. Every operator action is audited."""

from __future__ import annotations

import asyncio

import pytest
from asyncua import ua

from robostar.commands.control import EmergencyStop, ResetAlarms
from robostar.serve.lease import Who
from robostar.types import Alarm

from .conftest import (
    ACKNOWLEDGE,
    CONFIRM,
    ONE_SHOT_SHELVE,
    TIMED_SHELVE,
    UNSHELVE,
    Events,
    Model,
    RaiseAlarm,
    Setup,
    ack_args,
    audited,
    call,
    connect,
    field,
    serving,
    subscribe,
    text,
)

pytestmark = pytest.mark.timeout(120)

TESTER = Who("tester", "cli")


def test_acknowledge_and_confirm_a_real_alarm(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            line = server.line("cell1")
            handler = Events()
            subscription = await subscribe(client, handler)
            await line.execute(EmergencyStop(), who=TESTER, implicit_lease=True)
            raised = await handler.next_of(9001, 0, "the alarm's event")
            assert raised.Active is True and raised.Retain is True
            assert field(raised, "AckedState/Id") is False
            assert text(field(raised, "AckedState")) == "Unacknowledged"
            assert field(raised, "ConfirmedState/Id") is False
            condition = client.get_node(field(raised, "NodeId"))  # the ConditionId

            # a viewer may see the alarm but not acknowledge it
            async with connect(server, opcua_setup, "vic") as viewer:
                as_viewer = viewer.get_node(field(raised, "NodeId"))
                refused = await call(as_viewer, ACKNOWLEDGE, *ack_args(raised, "no"))
                assert refused.value == ua.StatusCodes.BadUserAccessDenied
            # confirming comes after acknowledging
            early = await call(condition, CONFIRM, *ack_args(raised, "too early"))
            assert early.value == ua.StatusCodes.BadInvalidState

            assert (await call(condition, ACKNOWLEDGE, *ack_args(raised, "seen"))).is_good()
            acked = await handler.next_of(9001, 1, "the acknowledgement's event")
            assert field(acked, "AckedState/Id") is True and acked.Active is True
            assert text(field(acked, "Comment")) == "seen"
            assert field(acked, "ClientUserId") == "olga"
            again = await call(condition, ACKNOWLEDGE, *ack_args(acked, "again"))
            assert again.value == ua.StatusCodes.BadConditionBranchAlreadyAcked
            # an event id that is not the condition's last one
            stale = await call(condition, CONFIRM, *ack_args(raised, "stale"))
            assert stale.value == ua.StatusCodes.BadEventIdUnknown

            # the controller clears it: inactive, still retained until confirmed
            await line.execute(ResetAlarms(), who=TESTER, implicit_lease=True)
            cleared = await handler.next_of(9001, 2, "the clearing's event")
            assert cleared.Active is False and cleared.Retain is True
            late = Events()
            late_subscription = await Model(client).refresh_conditions(late)
            replayed = await late.next_of(9001, 0, "the replay of the unconfirmed condition")
            assert replayed.Active is False and field(replayed, "AckedState/Id") is True
            await late_subscription.delete()

            assert (await call(condition, CONFIRM, *ack_args(cleared, "fixed"))).is_good()
            confirmed = await handler.next_of(9001, 3, "the confirmation's event")
            assert field(confirmed, "ConfirmedState/Id") is True
            assert confirmed.Retain is False  # of no more interest: gone from alarm lists
            after = Events()
            after_subscription = await Model(client).refresh_conditions(after)
            await asyncio.sleep(0.5)  # a replay would have come by now
            assert after.of(9001) == []
            await after_subscription.delete()
            await subscription.delete()
        mine = audited(opcua_setup)
        assert ("olga", "Acknowledge(alarm=9001)", "ok") in mine
        assert ("olga", "Confirm(alarm=9001)", "ok") in mine
        assert ("vic", "Acknowledge(alarm=9001)", "refused: not an operator") in mine

    asyncio.run(main())


def test_shelving_hides_an_alarm_for_a_time_or_until_it_clears(raised_alarm: RaiseAlarm) -> None:
    async def main() -> None:
        async with raised_alarm(Alarm(1001, "door open")) as alarm:
            handler = alarm.events
            assert alarm.raised.SuppressedOrShelved is False
            shelving = await alarm.condition.get_child(["0:ShelvingState"])

            not_shelved = await call(shelving, UNSHELVE)
            assert not_shelved.value == ua.StatusCodes.BadConditionNotShelved
            too_long = await call(shelving, TIMED_SHELVE, ua.Variant(1e12, ua.VariantType.Double))
            assert too_long.value == ua.StatusCodes.BadShelvingTimeOutOfRange

            assert (
                await call(shelving, TIMED_SHELVE, ua.Variant(300.0, ua.VariantType.Double))
            ).is_good()
            shelved = await handler.next_of(1001, 1, "the shelving's event")
            assert shelved.SuppressedOrShelved is True and shelved.Active is True
            back = await handler.next_of(1001, 2, "the end of the timed shelve")
            assert back.SuppressedOrShelved is False

            assert (await call(shelving, ONE_SHOT_SHELVE)).is_good()
            one_shot = await handler.next_of(1001, 3, "the one-shot shelve's event")
            assert one_shot.SuppressedOrShelved is True
            alarm.server.line("cell1").model.set("alarms", ())
            cleared = await handler.next_of(1001, 4, "the clearing's event")
            # a one-shot shelve ends when the alarm clears
            assert cleared.Active is False and cleared.SuppressedOrShelved is False

    asyncio.run(main())


def test_an_operator_comments_on_an_alarm(raised_alarm: RaiseAlarm) -> None:
    add_comment = ua.NodeId(ua.ObjectIds.ConditionType_AddComment)

    async def main() -> None:
        async with raised_alarm(Alarm(1003, "gripper")) as alarm:
            condition, raised = alarm.condition, alarm.raised
            assert (await call(condition, add_comment, *ack_args(raised, "on my way"))).is_good()
            commented = await alarm.events.next_of(1003, 1, "the comment's event")
            assert text(field(commented, "Comment")) == "on my way"
            assert field(commented, "AckedState/Id") is False  # a comment acknowledges nothing
            stale = await call(condition, add_comment, *ack_args(raised, "again"))
            assert stale.value == ua.StatusCodes.BadEventIdUnknown

    asyncio.run(main())
