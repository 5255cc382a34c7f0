"""The N1's alarms as OPC UA alarm conditions, as a SCADA alarm list uses them with asyncua's
real client: an alarm raises an unacknowledged, unconfirmed condition; operators (only) acknowledge
and confirm it on the condition, naming its last event; it stays retained (and is replayed by
ConditionRefresh) until it is inactive, acknowledged and confirmed; shelving hides it from alarm
lists for a time or until it clears. Every operator action is audited."""

from __future__ import annotations

import asyncio
import json
from typing import Any

import pytest
from asyncua import ua

from robostar.commands.control import EmergencyStop, ResetAlarms
from robostar.serve.lease import Who
from robostar.types import Alarm

from .conftest import Model, Setup, connect, serving, until

pytestmark = pytest.mark.timeout(120)

TESTER = Who("tester", "cli")
ACKNOWLEDGE = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
CONFIRM = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Confirm)
TIMED_SHELVE = ua.NodeId(ua.ObjectIds.ShelvedStateMachineType_TimedShelve)
ONE_SHOT_SHELVE = ua.NodeId(ua.ObjectIds.ShelvedStateMachineType_OneShotShelve)
UNSHELVE = ua.NodeId(ua.ObjectIds.ShelvedStateMachineType_Unshelve)


class Events:
    def __init__(self) -> None:
        self.events: list[Any] = []

    def event_notification(self, event: Any) -> None:
        self.events.append(event)

    def of(self, code: int) -> list[Any]:
        return [e for e in self.events if getattr(e, "AlarmCode", None) == code]

    async def next_of(self, code: int, seen: int, what: str) -> Any:
        """The first event of ``code`` after the ``seen`` ones already had."""

        async def more() -> bool:
            return len(self.of(code)) > seen

        await until(more, what=what)
        return self.of(code)[seen]


def field(event: Any, name: str) -> Any:
    return getattr(event, name)


def text(value: Any) -> str:
    return value.Text if isinstance(value, ua.LocalizedText) else str(value)


async def call(node: Any, method: ua.NodeId, *args: ua.Variant) -> ua.StatusCode:
    """Call ``method`` on ``node``; the status code it ends with (Good, or the refusal's)."""
    try:
        await node.call_method(method, *args)
    except ua.UaStatusCodeError as exc:
        return ua.StatusCode(exc.code)
    return ua.StatusCode(ua.StatusCodes.Good)


def ack_args(event: Any, comment: str) -> tuple[ua.Variant, ua.Variant]:
    return (
        ua.Variant(field(event, "EventId"), ua.VariantType.ByteString),
        ua.Variant(ua.LocalizedText(comment), ua.VariantType.LocalizedText),
    )


async def subscribe(client: Any, handler: Any) -> Any:
    model = Model(client)
    subscription = await client.create_subscription(20, handler)
    await subscription.subscribe_alarms_and_conditions(
        await model.system(), await model.alarm_event_type()
    )
    return subscription


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
        records = [
            json.loads(r) for r in (opcua_setup.state / "audit.jsonl").read_text().splitlines()
        ]
        mine = [(r["who"], r["what"], r["outcome"]) for r in records if r["face"] == "opcua"]
        assert ("olga", "Acknowledge(alarm=9001)", "ok") in mine
        assert ("olga", "Confirm(alarm=9001)", "ok") in mine
        assert ("vic", "Acknowledge(alarm=9001)", "refused: not an operator") in mine

    asyncio.run(main())


def test_shelving_hides_an_alarm_for_a_time_or_until_it_clears(opcua_setup: Setup) -> None:
    async def main() -> None:
        # a slow poller: the alarms the test puts in the model stay there
        async with (
            serving(opcua_setup, poll=30.0) as server,
            connect(server, opcua_setup) as client,
        ):
            line = server.line("cell1")
            handler = Events()
            subscription = await subscribe(client, handler)
            line.model.set("alarms", (Alarm(1001, "door open"),))
            raised = await handler.next_of(1001, 0, "the alarm's event")
            assert raised.SuppressedOrShelved is False
            condition = client.get_node(field(raised, "NodeId"))
            shelving = await condition.get_child(["0:ShelvingState"])

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
            line.model.set("alarms", ())
            cleared = await handler.next_of(1001, 4, "the clearing's event")
            # a one-shot shelve ends when the alarm clears
            assert cleared.Active is False and cleared.SuppressedOrShelved is False
            await subscription.delete()

    asyncio.run(main())


def test_an_operator_comments_on_an_alarm(opcua_setup: Setup) -> None:
    add_comment = ua.NodeId(ua.ObjectIds.ConditionType_AddComment)

    async def main() -> None:
        async with (
            serving(opcua_setup, poll=30.0) as server,
            connect(server, opcua_setup) as client,
        ):
            handler = Events()
            subscription = await subscribe(client, handler)
            server.line("cell1").model.set("alarms", (Alarm(1003, "gripper"),))
            raised = await handler.next_of(1003, 0, "the alarm's event")
            condition = client.get_node(field(raised, "NodeId"))
            assert (await call(condition, add_comment, *ack_args(raised, "on my way"))).is_good()
            commented = await handler.next_of(1003, 1, "the comment's event")
            assert text(field(commented, "Comment")) == "on my way"
            assert field(commented, "AckedState/Id") is False  # a comment acknowledges nothing
            stale = await call(condition, add_comment, *ack_args(raised, "again"))
            assert stale.value == ua.StatusCodes.BadEventIdUnknown
            await subscription.delete()

    asyncio.run(main())
