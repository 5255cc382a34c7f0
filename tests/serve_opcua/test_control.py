"""A line's control lease through OPC UA, with asyncua's real client: the Control object under
the line's system node says who holds the lease (Free, Holder, Face, Until, SecondsLeft,
OneShot) as it is when read, whichever face took it, and subscribers see it change; an
operator on a signed channel takes and releases it with TakeControl / ReleaseControl, a viewer
may not, a lease held by another is BadLocked, a bad Seconds is refused before anything
happens, and every take, release and refusal is audited."""

from __future__ import annotations

import asyncio
import datetime as dt
import json
from typing import Any

import pytest
from asyncua import ua

from robostar.commands.control import SetSpeed
from robostar.serve.lease import LeaseHeldError, Who

from .conftest import Model, Setup, connect, serving, until

pytestmark = pytest.mark.timeout(120)


async def call(node: Any, method: Any, *args: ua.Variant) -> tuple[ua.StatusCode, Any]:
    try:
        result = await node.call_method(method, *args)
    except ua.UaStatusCodeError as exc:
        return ua.StatusCode(exc.code), None
    return ua.StatusCode(ua.StatusCodes.Good), result


async def control_of(client: Any) -> tuple[Any, dict[str, Any]]:
    control = await Model(client).path("ven:Control")
    _, _, vendor = await Model(client).ns()
    values = {}
    for name in ("Free", "Holder", "Face", "Until", "SecondsLeft", "OneShot"):
        values[name] = await (await control.get_child([f"{vendor}:{name}"])).read_value()
    return control, values


def seconds(value: float) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.Double)


def test_take_and_release_control(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            line = server.line("cell1")
            _, _, vendor = await Model(client).ns()
            take, release = f"{vendor}:TakeControl", f"{vendor}:ReleaseControl"
            control, values = await control_of(client)
            assert values["Free"] is True and values["Holder"] == ""

            for bad in (-1.0, float("nan"), 1e9):
                code, _ = await call(control, take, seconds(bad))
                assert code.value == ua.StatusCodes.BadInvalidArgument, bad
            assert line.control().free  # a refused take takes nothing

            async with connect(server, opcua_setup, "vic") as viewer:
                as_viewer, _ = await control_of(viewer)
                code, _ = await call(as_viewer, take, seconds(60.0))
                assert code.value == ua.StatusCodes.BadUserAccessDenied

            code, until_ = await call(control, take, seconds(60.0))
            assert code.is_good()
            assert isinstance(until_, dt.datetime)
            _, values = await control_of(client)
            assert values["Free"] is False and values["OneShot"] is False
            assert (values["Holder"], values["Face"]) == ("olga", "opcua")
            assert 0 < values["SecondsLeft"] <= 60.0
            state = line.control()
            assert (state.holder, state.face) == ("olga", "opcua")
            # the lease is the line's: another consumer's write is refused while olga holds it
            with pytest.raises(LeaseHeldError):
                await line.execute(SetSpeed(1, 500), who=Who("ann", "api"), implicit_lease=True)

            assert (await call(control, release))[0].is_good()
            _, values = await control_of(client)
            assert values["Free"] is True and values["SecondsLeft"] == 0.0
            code, _ = await call(control, release)
            assert code.value == ua.StatusCodes.BadInvalidState  # nothing held

            # held by another face: BadLocked, and a read names the holder at once
            line.take_control(Who("ann", "api"), 30.0)
            _, values = await control_of(client)
            assert (values["Holder"], values["Face"]) == ("ann", "api")
            code, _ = await call(control, take, seconds(0.0))
            assert code.value == ua.StatusCodes.BadLocked
            line.release_control(Who("ann", "api"))
        records = [
            json.loads(r) for r in (opcua_setup.state / "audit.jsonl").read_text().splitlines()
        ]
        mine = [(r["who"], r["what"], r["outcome"]) for r in records if r["face"] == "opcua"]
        assert any(
            (who, what) == ("olga", "lease take") and o.startswith("ok") for who, what, o in mine
        ), mine
        assert ("olga", "lease release", "ok") in mine
        assert ("olga", "lease release", "not held: nothing released") in mine
        assert ("vic", "lease take", "refused: not an operator") in mine
        assert any(
            (who, what) == ("olga", "lease take") and o.startswith("refused: Seconds")
            for who, what, o in mine
        )
        assert any(
            (who, what) == ("olga", "lease take") and "held by ann" in o for who, what, o in mine
        ), mine

    asyncio.run(main())


class Changes:
    def __init__(self) -> None:
        self.values: list[Any] = []

    def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
        self.values.append(value)


def test_subscribers_see_who_takes_control(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            line = server.line("cell1")
            control, _ = await control_of(client)
            _, _, vendor = await Model(client).ns()
            holder = await control.get_child([f"{vendor}:Holder"])
            handler = Changes()
            subscription = await client.create_subscription(20, handler)
            await subscription.subscribe_data_change(holder)
            line.take_control(Who("ann", "api"), 30.0)

            async def named() -> bool:
                return "ann" in handler.values

            await until(named, what="the holder's name to reach the subscriber")
            line.release_control(Who("ann", "api"))

            async def freed() -> bool:
                return handler.values[-1] == ""

            await until(freed, what="the release to reach the subscriber")
            await subscription.delete()

    asyncio.run(main())
