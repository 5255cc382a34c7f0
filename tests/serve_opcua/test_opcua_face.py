"""The OPC UA face with asyncua's real client: the Robotics model by browse names, values that
follow the simulator, subscriptions, alarm events, gated methods, refused writes, security
defaults, the nodeset cache (issue #16)."""

from __future__ import annotations

import asyncio
import contextlib
import copy
import json
import random
import socket
from pathlib import Path
from typing import Any

import pytest
from asyncua import Client, ua
from asyncua.common.subscription import DataChangeNotif

from robostar.commands.control import ResetAlarms, SetSpeed
from robostar.commands.motion import Home, Move
from robostar.commands.status import ReadPosition
from robostar.commands.variables import WriteGlobalFloat, WriteGlobalInt
from robostar.errors import UsageError
from robostar.serve.faces.opcua import settings_from
from robostar.serve.faces.opcua.security import SignInBudget, UsersManager
from robostar.serve.lease import Who
from robostar.serve.model import Quality
from robostar.serve.users import LoginLimiter, Role, UserStore
from robostar.sim import SimConfig, VirtualController
from robostar.sim.listeners import SimServer
from robostar.types import Alarm, CoordSystem, MotionType, PositionKind

from .conftest import PASSWORDS, Model, Setup, connect, read_values, serving, until

pytestmark = pytest.mark.timeout(120)

TESTER = Who("tester", "cli")


def run(coro: Any) -> Any:
    return asyncio.run(coro)


class Changes:
    """An asyncua subscription handler keeping every data change and event."""

    def __init__(self) -> None:
        self.values: list[tuple[Any, Any]] = []
        self.events: list[Any] = []

    def datachange_notification(self, node: Any, value: Any, data: DataChangeNotif) -> None:
        self.values.append((node, value))

    def event_notification(self, event: Any) -> None:
        self.events.append(event)


async def _repeated_names(node: Any, path: str = "") -> list[str]:
    names: list[str] = []
    repeated = []
    for child in await node.get_children():
        name = (await child.read_browse_name()).to_string()
        if name in names:
            repeated.append(f"{path}/{name}")
        names.append(name)
        if await child.read_node_class() == ua.NodeClass.Object:
            repeated += await _repeated_names(child, f"{path}/{name}")
    return repeated


def _audit(setup: Setup) -> list[dict[str, Any]]:
    """The audit log's records so far (shared by the session's servers)."""
    path = setup.state / "audit.jsonl"
    lines = path.read_text().splitlines() if path.exists() else []
    return [json.loads(line) for line in lines]


async def _home(server: Any) -> None:
    line = server.line("cell1")
    await line.execute(Home(1), who=TESTER, implicit_lease=True)
    line.lease.release(TESTER)

    async def homed() -> bool:
        status = line.model.get("ch1/status")
        return status is not None and status.value.origin and not status.value.running

    await until(homed, what="channel 1 homed")


# -- the information model ----------------------------------------------------------------
def test_the_robotics_structure_by_browse_names(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            model = Model(client)
            _, rob, _ = await model.ns()
            system = await model.system()
            type_def = await system.read_type_definition()
            assert type_def == ua.NodeId(1002, rob)  # MotionDeviceSystemType
            names = {(await n.read_browse_name()).Name for n in await system.get_children()}
            assert {"MotionDevices", "Controllers", "SafetyStates"} <= names
            # no placeholder of the type is left in the instance
            assert not any(name.startswith("<") for name in names)
            device = await model.path("rob:MotionDevices", "ven:Channel1")
            assert await device.read_type_definition() == ua.NodeId(1004, rob)
            name = await model.path("di:ComponentName")
            assert (await name.read_value()).Text == "cell1 (Robostar N1)"
            maker = await model.path("rob:MotionDevices", "ven:Channel1", "di:Manufacturer")
            assert (await maker.read_value()).Text == "Robostar"
            category = await model.path(
                "rob:MotionDevices", "ven:Channel1", "rob:MotionDeviceCategory"
            )
            assert await category.read_value() == 2  # SCARA_ROBOT: the simulator's channel 1
            axes = await model.path("rob:MotionDevices", "ven:Channel1", "rob:Axes")
            axis_names = sorted(
                [(await a.read_browse_name()).Name for a in await axes.get_children()]
            )
            assert axis_names == ["Axis1", "Axis2", "Axis3", "Axis4"]
            profiles = []
            for axis in (1, 3):
                node = await model.path(
                    "rob:MotionDevices",
                    "ven:Channel1",
                    "rob:Axes",
                    f"ven:Axis{axis}",
                    "rob:MotionProfile",
                )
                profiles.append(await node.read_value())
            assert profiles == [1, 3]  # ROTARY (degrees), LINEAR (Z, mm)
            units = await (await model.axis_position(1, 3)).get_child(["0:EngineeringUnits"])
            assert (await units.read_value()).DisplayName.Text == "mm"
            speed = await model.path(
                "rob:MotionDevices", "ven:Channel1", "di:ParameterSet", "rob:SpeedOverride"
            )
            assert isinstance(await speed.read_value(), float)
            in_control = await model.path(
                "rob:MotionDevices", "ven:Channel1", "di:ParameterSet", "rob:InControl"
            )
            assert await in_control.read_value() in (True, False)
            task = await model.path("rob:Controllers", "ven:cell1", "rob:TaskControls")
            assert [(await t.read_browse_name()).Name for t in await task.get_children()] == [
                "Channel1",
                "Channel2",
            ]
            program = await model.path(
                "rob:Controllers",
                "ven:cell1",
                "rob:TaskControls",
                "ven:Channel1",
                "di:ParameterSet",
                "rob:TaskProgramName",
            )
            assert await program.read_value() == ""
            machine = await model.state_machine(1)
            methods = {(await m.read_browse_name()).Name for m in await machine.get_methods()}
            assert {"Start", "Stop", "LoadByName"} <= methods
            estop = await model.path(
                "rob:SafetyStates", "ven:cell1", "di:ParameterSet", "rob:EmergencyStop"
            )
            assert await estop.read_value() is False
            safety = await model.path("rob:SafetyStates", "ven:cell1")
            assert "Informational" in (await safety.read_description()).Text
            firmware = await model.path(
                "rob:Controllers",
                "ven:cell1",
                "rob:Software",
                "ven:Firmware",
                "di:SoftwareRevision",
            )
            assert await firmware.read_value() == server.line("cell1").info.version
            origin = await model.path(
                "rob:MotionDevices", "ven:Channel1", "ven:Robostar", "ven:OriginDone"
            )
            assert await origin.read_value() is False
            # browse paths are unambiguous: no two children of a node share a browse name
            assert await _repeated_names(system) == []

    run(main())


async def _mandatory_children(client: Any, type_id: ua.NodeId) -> set[str]:
    """The browse names of a type's mandatory children, its supertypes' included (the
    placeholders, whose names are the instance's to choose, left out)."""
    names: set[str] = set()
    node = client.get_node(type_id)
    while True:
        for child in await node.get_children():
            rules = await child.get_referenced_nodes(refs=ua.ObjectIds.HasModellingRule)
            if rules and rules[0].nodeid == ua.NodeId(ua.ObjectIds.ModellingRule_Mandatory):
                names.add((await child.read_browse_name()).to_string())
        parents = await node.get_referenced_nodes(
            refs=ua.ObjectIds.HasSubtype, direction=ua.BrowseDirection.Inverse
        )
        if not parents or parents[0].nodeid.NamespaceIndex == 0:
            return names
        node = parents[0]


def test_every_instance_has_its_types_mandatory_children(opcua_setup: Setup) -> None:
    """What a generic client checks: each object of a companion-spec type under the line has
    every child its type declares mandatory, under the same browse name."""

    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            model = Model(client)
            di, rob, _ = await model.ns()
            checked = 0
            missing: list[str] = []
            pending = [(await model.system(), "cell1")]
            while pending:
                node, path = pending.pop()
                type_id = await node.read_type_definition()
                if type_id is not None and type_id.NamespaceIndex in (di, rob):
                    have = {
                        (await c.read_browse_name()).to_string() for c in await node.get_children()
                    }
                    need = await _mandatory_children(client, type_id)
                    missing += [f"{path}/{name}" for name in sorted(need - have)]
                    checked += 1
                for child in await node.get_children():
                    if await child.read_node_class() == ua.NodeClass.Object:
                        name = (await child.read_browse_name()).Name
                        pending.append((child, f"{path}/{name}"))
            assert missing == []
            assert checked >= 15  # the system, devices, axes, controller, tasks, safety, ...

    run(main())


def test_positions_follow_the_simulator_while_it_moves(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            line = server.line("cell1")
            await _home(server)
            model = Model(client)
            node = await model.axis_position(1, 1)
            before = line.model.get("ch1/angles")
            assert before is not None
            seen: list[float] = [before.value.axes[0]]

            async def collect() -> None:
                # read every change as it comes: a subscription keeps only the latest per key
                with line.model.subscribe() as changes:
                    async for change in changes:
                        if change.key == "ch1/angles":
                            seen.append(change.sample.value.axes[0])

            collector = asyncio.create_task(collect())
            await asyncio.sleep(0)
            # a slow move (1 % speed: about 1.1 s of real time at speedup 20), so that a loaded
            # machine's late first read still finds the arm moving
            await line.execute(SetSpeed(1, 10), who=TESTER, implicit_lease=True)
            await line.execute(
                Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((80.0, 40.0, 50.0, 10.0),)),
                who=TESTER,
                implicit_lease=True,
            )

            async def stopped() -> bool:
                status = line.model.get("ch1/status")
                return status is not None and not status.value.running

            # read until the move has ended (at least 60 reads), as a client polling it would
            readings: list[tuple[float, Any]] = []
            while len(readings) < 60 or not await stopped():
                data = await node.read_data_value()
                readings.append((data.Value.Value, data.SourceTimestamp))
                await asyncio.sleep(0.02)
            collector.cancel()
            values = [v for v, _ in readings]
            # every value a client read is one the controller reported, and it moved
            assert all(any(abs(v - s) < 1e-9 for s in seen) for v in values), (values, seen)
            assert len(set(values)) > 2, values

            await until(stopped, what="the move to end")
            direct = await line.read(ReadPosition(1, PositionKind.ANGLE), max_age=0)

            async def matches() -> bool:
                return abs(await node.read_value() - direct.axes[0]) < 1e-9

            await until(matches, what="the OPC UA value to match the controller's")
            assert direct.axes[0] == pytest.approx(80.0)
            data = await node.read_data_value()
            assert data.StatusCode.is_good()
            assert data.SourceTimestamp is not None

    run(main())


def test_a_subscriber_receives_changes(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            model = Model(client)
            speed = await model.path(
                "rob:MotionDevices", "ven:Channel1", "di:ParameterSet", "rob:SpeedOverride"
            )
            handler = Changes()
            subscription = await client.create_subscription(20, handler)
            await subscription.subscribe_data_change(speed)
            line = server.line("cell1")
            await line.execute(SetSpeed(1, 250), who=TESTER, implicit_lease=True)

            async def heard() -> bool:
                return any(value == 25.0 for _, value in handler.values)

            await until(heard, what="SpeedOverride 25 % by subscription")
            await subscription.delete()

    run(main())


def test_values_carry_the_models_quality(opcua_setup: Setup) -> None:
    async def main() -> None:
        # a slow poller: the test's marks are not overwritten before they are read
        async with (
            serving(opcua_setup, poll=30.0) as server,
            connect(server, opcua_setup) as client,
        ):
            line = server.line("cell1")
            node = await Model(client).axis_position(1, 1)

            async def status_is(name: str) -> bool:
                # a read that accepts the model's value, whatever its age (maxAge 0 would read
                # the line and show its answer instead)
                (data,) = await read_values(client, [node], 3_600_000)
                return data.StatusCode.value == getattr(ua.StatusCodes, name)

            await until(lambda: status_is("Good"), what="Good")
            line.model.mark(Quality.STALE)
            await until(lambda: status_is("UncertainLastUsableValue"), what="Uncertain")
            line.model.mark(Quality.LINE_DOWN)
            await until(lambda: status_is("BadCommunicationError"), what="Bad")

    run(main())


def test_configured_global_variables_are_read(opcua_setup: Setup) -> None:
    async def main() -> None:
        options = {"globals": {"int": [0, 3], "float": [1]}, "globals_interval": 0.1}
        async with (
            serving(opcua_setup, **options) as server,
            connect(server, opcua_setup) as client,
        ):
            line = server.line("cell1")
            await line.execute(WriteGlobalInt(3, 42), who=TESTER, implicit_lease=True)
            await line.execute(WriteGlobalFloat(1, -2.5), who=TESTER, implicit_lease=True)
            model = Model(client)
            folder = ("rob:Controllers", "ven:cell1", "ven:Robostar")
            int3 = await model.path(*folder, "ven:GlobalInt3")
            float1 = await model.path(*folder, "ven:GlobalFloat1")

            async def written() -> bool:
                return await int3.read_value() == 42 and await float1.read_value() == -2.5

            await until(written, what="the globals read back")
            assert (await int3.read_data_value()).StatusCode.is_good()

    run(main())


def test_a_line_down_at_start_is_built_again_when_it_comes_up(opcua_setup: Setup) -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]

    async def main() -> None:
        url = f"tcp://127.0.0.1:{port}"
        async with serving(opcua_setup, url=url) as server, connect(server, opcua_setup) as client:
            model = Model(client)
            online = await model.path("rob:Controllers", "ven:cell1", "ven:Robostar", "ven:Online")
            assert await online.read_value() is False
            axes = await model.path("rob:MotionDevices", "ven:Channel1", "rob:Axes")
            assert await axes.get_children() == []  # nothing known of the robot yet
            sim = SimServer(VirtualController(SimConfig()), port=port).start()
            try:

                async def rebuilt() -> bool:
                    try:
                        node = await model.axis_position(1, 4)
                        data = await node.read_data_value(raise_on_bad_status=False)
                    except ua.UaStatusCodeError:
                        return False
                    return data.StatusCode.is_good()

                await until(rebuilt, timeout=30, what="the device made again with its axes")
                online = await model.path(
                    "rob:Controllers", "ven:cell1", "ven:Robostar", "ven:Online"
                )
                assert await online.read_value() is True
            finally:
                sim.close()

    run(main())


# -- alarms and methods ----------------------------------------------------------------------
def test_emergency_stop_raises_an_alarm_event_and_reset_clears_it(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            model = Model(client)
            _, _, vendor = await model.ns()
            handler = Changes()
            subscription = await client.create_subscription(20, handler)
            await subscription.subscribe_events(
                await model.system(), await model.alarm_event_type()
            )
            controller = await model.path("rob:Controllers", "ven:cell1", "ven:Robostar")
            result = await controller.call_method(f"{vendor}:EmergencyStop")
            assert result == 0

            async def raised() -> bool:
                return any(e.Active for e in handler.events)

            await until(raised, what="an alarm event")
            event = next(e for e in handler.events if e.Active)
            assert event.AlarmCode == 9001 and "Emergency" in event.AlarmText
            assert event.Line == "cell1" and event.Severity >= 700
            assert event.Retain is True and event.ConditionName == "9001"
            # a client that comes later asks for the active conditions (ConditionRefresh)
            late = Changes()
            late_sub = await model.refresh_conditions(late)

            async def refreshed() -> bool:
                return any(getattr(e, "AlarmCode", None) == 9001 for e in late.events)

            await until(refreshed, what="the active alarm replayed by ConditionRefresh")
            await late_sub.delete()
            estop = await model.path(
                "rob:SafetyStates", "ven:cell1", "di:ParameterSet", "rob:EmergencyStop"
            )
            await until(estop.read_value, what="SafetyStates EmergencyStop true")
            alarms = await model.path("rob:Controllers", "ven:cell1", "ven:Robostar", "ven:Alarms")
            assert any("9001" in text for text in await alarms.read_value())
            line = server.line("cell1")
            await line.execute(ResetAlarms(), who=TESTER, implicit_lease=True)

            async def cleared() -> bool:
                return any(not e.Active and e.AlarmCode == 9001 for e in handler.events)

            await until(cleared, what="the alarm's clearing event")
            await subscription.delete()
        audit = _audit(opcua_setup)
        assert any(
            r["who"] == "olga"
            and r["face"] == "opcua"
            and "EmergencyStop" in r["what"]
            and r["outcome"] == "ok"
            for r in audit
        )

    run(main())


def test_condition_refresh_replays_each_active_alarm(opcua_setup: Setup) -> None:
    async def main() -> None:
        # a slow poller: the alarms the test puts in the model stay there
        async with (
            serving(opcua_setup, poll=30.0) as server,
            connect(server, opcua_setup) as client,
        ):
            line = server.line("cell1")
            model = Model(client)

            async def refresh(expect: int) -> list[tuple[int, bool, bool]]:
                handler = Changes()
                subscription = await model.refresh_conditions(handler)

                async def replayed() -> bool:
                    return len(handler.events) >= expect

                await until(replayed, what="the replay")
                await asyncio.sleep(0.3)  # anything more the replay would send comes with it
                await subscription.delete()
                return sorted(
                    (e.AlarmCode, e.Retain, e.Active)
                    for e in handler.events
                    if hasattr(e, "AlarmCode")
                )

            line.model.set("alarms", (Alarm(1001, "first"), Alarm(1002, "second")))
            await asyncio.sleep(0.3)
            assert await refresh(2) == [(1001, True, True), (1002, True, True)]
            line.model.set("alarms", (Alarm(1001, "first"),))
            await asyncio.sleep(0.3)
            # cleared but not acknowledged: still of interest to an operator (OPC 10000-9)
            assert await refresh(2) == [(1001, True, True), (1002, True, False)]

    run(main())


def test_start_and_stop_need_the_operator_role(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server:
            await _home(server)
            line = server.line("cell1")
            async with connect(server, opcua_setup, "vic") as viewer:
                machine = await Model(viewer).state_machine(1)
                _, rob, _ = await Model(viewer).ns()
                for method, args in (("Start", ()), ("Stop", (0,)), ("LoadByName", ("DEMO.JOB",))):
                    with pytest.raises(ua.UaStatusCodeError) as refused:
                        await machine.call_method(f"{rob}:{method}", *args)
                    assert refused.value.code == ua.StatusCodes.BadUserAccessDenied
            assert line.model.get("ch1/job").value is None  # nothing reached the controller
            async with connect(server, opcua_setup, "olga") as operator:
                model = Model(operator)
                machine = await model.state_machine(1)
                _, rob, _ = await model.ns()
                with pytest.raises(ua.UaStatusCodeError) as bad_name:
                    await machine.call_method(f"{rob}:LoadByName", "NO SUCH FILE.JOB")
                assert bad_name.value.code == ua.StatusCodes.BadInvalidArgument
                # refused by the N1 (no such file): the spec's E_SystemState
                assert await machine.call_method(f"{rob}:LoadByName", "NONE.JOB") == 1
                assert await machine.call_method(f"{rob}:LoadByName", "DEMO.JOB") == 0
                program = await model.path(
                    "rob:Controllers",
                    "ven:cell1",
                    "rob:TaskControls",
                    "ven:Channel1",
                    "di:ParameterSet",
                    "rob:TaskProgramName",
                )

                async def loaded() -> bool:
                    return await program.read_value() == "DEMO.JOB"

                await until(loaded, what="TaskProgramName DEMO.JOB")
                state = await machine.get_child(["0:CurrentState"])
                assert await machine.call_method(f"{rob}:Start") == 0

                async def executing() -> bool:
                    return (await state.read_value()).Text == "Executing"

                await until(executing, what="the state machine in Executing")
                assert (
                    await machine.call_method(f"{rob}:Stop", ua.Variant(0, ua.VariantType.Int64))
                    == 0
                )

                async def not_running() -> bool:
                    return (await state.read_value()).Text != "Executing"

                await until(not_running, what="the job stopped")
                # another consumer takes the lease: the operator's Start is refused
                line.lease.release(Who("olga", "opcua"))
                line.lease.acquire(Who("someone", "api"))
                with pytest.raises(ua.UaStatusCodeError) as locked:
                    await machine.call_method(f"{rob}:Start")
                assert locked.value.code == ua.StatusCodes.BadLocked
        audit = _audit(opcua_setup)
        mine = [r for r in audit if r["face"] == "opcua"]
        assert any(r["who"] == "vic" and r["outcome"].startswith("refused") for r in mine)
        assert any(
            r["who"] == "olga" and "StartJob" in r["what"] and r["outcome"] == "ok" for r in mine
        )

    run(main())


def test_an_active_alarm_refuses_start_without_sending(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            model = Model(client)
            _, rob, vendor = await model.ns()
            controller = await model.path("rob:Controllers", "ven:cell1", "ven:Robostar")
            await controller.call_method(f"{vendor}:EmergencyStop")
            line = server.line("cell1")

            async def alarmed() -> bool:
                alarms = line.model.get("alarms")
                return alarms is not None and bool(alarms.value)

            await until(alarmed, what="the alarm in the model")
            before = len(_audit(opcua_setup))
            machine = await model.state_machine(1)
            assert await machine.call_method(f"{rob}:Start") == -3  # an alarm is active
            # LoadByName has the spec's own code for it, E_ActiveAlarm
            assert await machine.call_method(f"{rob}:LoadByName", "DEMO.JOB") == 3
        # refused by the face before the queue: the controller's own refusal would be audited
        # as an error of an exchange that went out
        calls = [r for r in _audit(opcua_setup)[before:] if r["face"] == "opcua"]
        assert [r["outcome"] for r in calls] == ["refused: an alarm is active"] * 2

    run(main())


def test_writes_are_refused_even_to_an_operator(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            node = await Model(client).axis_position(1, 1)
            with pytest.raises(ua.UaStatusCodeError) as refused:
                await node.write_value(ua.DataValue(ua.Variant(42.0, ua.VariantType.Double)))
            assert refused.value.code == ua.StatusCodes.BadUserAccessDenied
            assert await node.read_value() != 42.0

    run(main())


# -- security defaults -----------------------------------------------------------------------
def test_anonymous_and_wrong_passwords_are_refused_by_default(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server:
            with pytest.raises(ua.UaError):
                async with connect(server, opcua_setup, None):
                    pass
            with pytest.raises(ua.UaError):
                async with connect(server, opcua_setup, "olga", password="not-her-password"):
                    pass
            face: Any = server.faces["opcua"]
            # a client that insists on no security, although no endpoint offers it, gets a
            # channel (asyncua makes one) but no session: no password is taken over it
            for user in ("vic", None):
                insisting = Client(face.address, timeout=10)
                if user is not None:
                    insisting.set_user(user)
                    insisting.set_password(PASSWORDS[user])
                with pytest.MonkeyPatch.context() as patch:
                    patch.setattr(Client, "find_endpoint", staticmethod(_no_security_endpoint))
                    with pytest.raises(ua.UaStatusCodeError) as refused:
                        await insisting.connect()
                assert refused.value.code in (
                    ua.StatusCodes.BadUserAccessDenied,  # the password, not over this channel
                    ua.StatusCodes.BadIdentityTokenRejected,  # no anonymous tokens at all
                )
                with contextlib.suppress(Exception):
                    await insisting.disconnect()
            endpoints = await Client(face.address).connect_and_get_server_endpoints()
            modes = {e.SecurityMode for e in endpoints}
            assert modes == {ua.MessageSecurityMode.Sign, ua.MessageSecurityMode.SignAndEncrypt}
            policies = {e.SecurityPolicyUri.rsplit("#", 1)[-1] for e in endpoints}
            assert policies == {"Basic256Sha256"}
            tokens = {t.TokenType for e in endpoints for t in e.UserIdentityTokens}
            assert tokens == {ua.UserTokenType.UserName}

    run(main())


def _no_security_endpoint(endpoints: Any, mode: Any, uri: Any) -> Any:
    """In place of asyncua's Client.find_endpoint, which would refuse: the server's first
    endpoint, for a channel with no security, the password to be sent in the clear."""
    endpoint = copy.deepcopy(endpoints[0])
    for token in endpoint.UserIdentityTokens:
        token.SecurityPolicyUri = "http://opcfoundation.org/UA/SecurityPolicy#None"
    return endpoint


def test_anonymous_read_opens_a_read_only_unsigned_endpoint(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup, allow_anonymous_read=True) as server:
            async with connect(server, opcua_setup, None, mode="None_") as anonymous:
                model = Model(anonymous)
                node = await model.axis_position(1, 1)
                assert isinstance(await node.read_value(), float)
                _, rob, _ = await model.ns()
                machine = await model.state_machine(1)
                with pytest.raises(ua.UaStatusCodeError) as refused:
                    await machine.call_method(f"{rob}:Start")
                assert refused.value.code == ua.StatusCodes.BadUserAccessDenied
            # a password never crosses the unsigned endpoint: an operator cannot sign in there
            with pytest.raises(ua.UaStatusCodeError):
                async with connect(server, opcua_setup, "olga", mode="None_"):
                    pass
            assert not server.line("cell1").model.get("alarms").value

    run(main())


def test_repeated_wrong_passwords_hold_the_name_off(opcua_setup: Setup) -> None:
    users = UserStore(opcua_setup.users)
    clock = [1000.0]
    limiter = LoginLimiter(attempts=5, window=60.0, clock=lambda: clock[0])
    manager = UsersManager(
        users, allow_anonymous=False, limiter=limiter, budget=SignInBudget(rate=1e6, burst=1000)
    )
    cert = b"a channel certificate"
    assert manager.get_user(None, "olga", PASSWORDS["olga"], cert) is not None
    for _ in range(5):
        assert manager.get_user(None, "olga", "wrong-password", cert) is None
    assert manager.get_user(None, "olga", PASSWORDS["olga"], cert) is None  # held off
    assert manager.get_user(None, "vic", PASSWORDS["vic"], cert) is not None  # others are not
    clock[0] += 61
    assert manager.get_user(None, "olga", PASSWORDS["olga"], cert) is not None
    assert manager.get_user(None, None, None) is None  # anonymous is off


def test_hostile_bytes_on_the_port_do_not_harm_the_server(opcua_setup: Setup) -> None:
    rng = random.Random(16)
    junk = [
        b"",
        b"GET / HTTP/1.1\r\nHost: x\r\n\r\n",
        b"HELF" + (0xFFFFFFF0).to_bytes(4, "little") + bytes(64),  # a huge announced size
        b"HELF\x1c\x00\x00\x00" + bytes(20),  # a truncated hello
        b"MSGF" + bytes(4) + bytes(100),
        *(bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 400))) for _ in range(20)),
    ]

    async def main() -> None:
        async with serving(opcua_setup) as server:
            face: Any = server.faces["opcua"]
            for payload in junk:
                reader, writer = await asyncio.open_connection("127.0.0.1", face.port)
                writer.write(payload)
                with contextlib.suppress(OSError):
                    await writer.drain()
                with contextlib.suppress(OSError, TimeoutError):
                    await asyncio.wait_for(reader.read(1024), 0.1)
                writer.close()
                with contextlib.suppress(OSError):
                    await writer.wait_closed()
            async with connect(server, opcua_setup) as client:
                node = await Model(client).axis_position(1, 1)
                assert isinstance(await node.read_value(), float)
            assert server.line("cell1").up

    run(main())


def test_a_taken_port_is_a_clear_error(opcua_setup: Setup) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]

        async def main() -> None:
            with pytest.raises(UsageError, match=f"opcua: cannot serve .*:{port}"):
                async with serving(opcua_setup, listen=f"127.0.0.1:{port}"):
                    pass

        run(main())


def test_the_rulesets_refuse_writes_and_mark_channels(opcua_setup: Setup) -> None:
    from asyncua.crypto.permission_rules import User, UserRole

    from robostar.serve.faces.opcua.security import (
        RefuseAllRuleset,
        RoleRuleset,
        current_caller,
    )

    users = UserStore(opcua_setup.users)
    olga = User(role=UserRole.User, name="olga")
    write = ua.NodeId(ua.ObjectIds.WriteRequest_Encoding_DefaultBinary)
    read = ua.NodeId(ua.ObjectIds.ReadRequest_Encoding_DefaultBinary)
    call = ua.NodeId(ua.ObjectIds.CallRequest_Encoding_DefaultBinary)
    signed, unsigned = RoleRuleset(users, secure=True), RoleRuleset(users, secure=False)
    # a write request passes a signed channel only, to be checked value by value (only the
    # setpoints, for operators: test_setpoints.py)
    assert signed.check_validity(olga, write, None) is True
    assert unsigned.check_validity(olga, write, None) is False
    assert signed.check_validity(olga, read, None) is True
    assert signed.check_validity(olga, call, None) is True
    caller = current_caller()
    assert caller is not None and caller.may_operate()
    assert unsigned.check_validity(olga, call, None) is True
    caller = current_caller()
    assert caller is not None and not caller.may_operate()  # unsigned: read-only
    assert signed.check_validity(User(role=UserRole.User, name="gone"), read, None) is False
    assert current_caller() is None  # a refused request leaves no caller behind
    assert RefuseAllRuleset().check_validity(olga, read, None) is False


def test_a_sign_in_budget_keeps_argon2_off_the_loop(opcua_setup: Setup) -> None:
    clock = [0.0]
    budget = SignInBudget(rate=5.0, burst=5, clock=lambda: clock[0])
    manager = UsersManager(UserStore(opcua_setup.users), allow_anonymous=False, budget=budget)
    cert = b"a channel certificate"
    for _ in range(5):
        assert manager.get_user(None, "olga", PASSWORDS["olga"], cert) is not None
    assert manager.get_user(None, "olga", PASSWORDS["olga"], cert) is None  # no hashing
    clock[0] += 0.2
    assert manager.get_user(None, "olga", PASSWORDS["olga"], cert) is not None
    assert manager.get_user(None, "olga", PASSWORDS["olga"], None) is None  # unsigned channel


def test_a_changed_users_file_takes_effect_while_running(tmp_path: Path) -> None:
    path = tmp_path / "users.toml"
    writer = UserStore(path)
    writer.add("ann", Role.OPERATOR, "operator-pass-2")
    reader = UserStore(path)
    assert reader.get("ann") is not None and reader.get("ann").role is Role.OPERATOR
    writer.add("ann", Role.VIEWER, "operator-pass-2")
    writer.add("bo", Role.VIEWER, "viewer-pass-22")
    reader.refresh(every=0)
    assert reader.get("ann").role is Role.VIEWER and reader.get("bo") is not None
    writer.remove("ann")
    reader.refresh(every=0)
    assert reader.get("ann") is None


def test_a_cache_others_can_write_is_never_loaded(tmp_path: Path) -> None:
    import pickle

    from robostar.serve.faces.opcua.nodesets import CachedInternalServer

    shared = tmp_path / "shared"
    shared.mkdir()
    inside = CachedInternalServer(shared)
    path = inside.cache_file
    assert path is not None
    path.write_bytes(pickle.dumps(({}, ["http://opcfoundation.org/UA/"])))
    path.chmod(0o600)
    shared.chmod(0o700)
    assert inside._read_cache(path) is not None  # private: taken
    shared.chmod(0o777)  # anyone could have put it there: a pickle is code
    assert inside._read_cache(path) is None
    shared.chmod(0o700)
    path.chmod(0o666)
    assert inside._read_cache(path) is None


def test_settings_are_checked(tmp_path: Any) -> None:
    users = str(tmp_path / "users.toml")
    with pytest.raises(UsageError, match="loopback"):
        settings_from({"listen": "0.0.0.0:4840", "users": users})
    assert settings_from({"listen": "0.0.0.0:4840", "users": users, "allow_remote": True})
    with pytest.raises(UsageError, match="only on a loopback"):
        settings_from(
            {"listen": "0.0.0.0:4840", "allow_remote": True, "allow_anonymous_read": True}
        )
    with pytest.raises(UsageError, match="nobody could sign in"):
        settings_from({"listen": "127.0.0.1:4840"})
    with pytest.raises(UsageError, match=r"opcua\.colour: unknown option"):
        settings_from({"users": users, "colour": "blue"})
    with pytest.raises(UsageError, match=r"opcua\.globals\.int"):
        settings_from({"users": users, "globals": {"int": [100000]}})
    with pytest.raises(UsageError, match=r"opcua\.globals:"):
        settings_from({"users": users, "globals": {"points": [1]}})
    with pytest.raises(UsageError, match="allow_anonymous_read"):
        settings_from({"users": users, "allow_anonymous_read": "yes"})


# -- startup ---------------------------------------------------------------------------------
def test_the_imported_nodesets_are_cached_for_the_next_start(
    opcua_setup: Setup, tmp_path: Any
) -> None:
    cache = tmp_path / "cache"

    async def start_once() -> tuple[bool, list[str], int]:
        async with serving(opcua_setup, cache_dir=str(cache)) as server:
            face: Any = server.faces["opcua"]
            async with connect(server, opcua_setup) as client:
                namespaces = await client.get_namespace_array()
                axes = await Model(client).path("rob:MotionDevices", "ven:Channel1", "rob:Axes")
                count = len(await axes.get_children())
                # a Robotics type browses the same either way
                types = await client.nodes.base_object_type.get_children()
                types += await client.nodes.object_types.get_children()
                types += await client.nodes.data_types.get_children()
                return face.load.cached, namespaces, count + len(types)

    cold = run(start_once())
    assert list(cache.glob("address-space-*.pickle"))
    warm = run(start_once())
    assert (cold[0], warm[0]) == (False, True)
    assert cold[1:] == warm[1:]
    (next(cache.glob("address-space-*.pickle"))).write_bytes(b"not a pickle")
    rebuilt = run(start_once())
    assert rebuilt == cold  # a broken cache is rebuilt, never trusted
