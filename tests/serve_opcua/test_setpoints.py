"""Writable setpoints: an operator writes a channel's SpeedOverride (percent) and the controller's
speed changes, through the line's lease and audit log; viewers, unsigned channels, values out of
range or of the wrong type, another consumer's lease, and every other variable are refused with
the status code a client expects."""

from __future__ import annotations

import asyncio
import json

import pytest
from asyncua import ua

from robostar.serve.lease import Who

from .conftest import Model, Setup, connect, serving, until

pytestmark = pytest.mark.timeout(120)


def double(value: object) -> ua.DataValue:
    return ua.DataValue(ua.Variant(value, ua.VariantType.Double))


async def refused(node: object, value: ua.DataValue) -> int:
    with pytest.raises(ua.UaStatusCodeError) as error:
        await node.write_value(value)  # type: ignore[attr-defined]
    return int(error.value.code)


def test_an_operator_writes_the_speed_override(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            line = server.line("cell1")
            model = Model(client)
            speed = await model.path(
                "rob:MotionDevices", "ven:Channel1", "di:ParameterSet", "rob:SpeedOverride"
            )
            access = await speed.read_attribute(ua.AttributeIds.UserAccessLevel)
            assert access.Value.Value & ua.AccessLevel.CurrentWrite.mask
            await speed.write_value(double(42.5))

            async def shown() -> bool:
                return await speed.read_value() == 42.5

            await until(shown, what="SpeedOverride 42.5 read back from the controller")
            sample = line.model.get("ch1/speed")
            assert sample is not None and sample.value == 425

            assert await refused(speed, double(150.0)) == ua.StatusCodes.BadOutOfRange
            text = ua.DataValue(ua.Variant("fast", ua.VariantType.String))
            assert await refused(speed, text) == ua.StatusCodes.BadTypeMismatch
            in_control = await model.path(
                "rob:MotionDevices", "ven:Channel1", "di:ParameterSet", "rob:InControl"
            )
            boolean = ua.DataValue(ua.Variant(True, ua.VariantType.Boolean))
            assert await refused(in_control, boolean) == ua.StatusCodes.BadUserAccessDenied
            async with connect(server, opcua_setup, "vic") as viewer:
                as_viewer = viewer.get_node(speed.nodeid)
                assert await refused(as_viewer, double(10.0)) == ua.StatusCodes.BadUserAccessDenied
            line.lease.release(Who("olga", "opcua"))
            line.lease.acquire(Who("someone", "api"))
            assert await refused(speed, double(10.0)) == ua.StatusCodes.BadLocked
            assert line.model.get("ch1/speed").value == 425  # nothing refused reached it
        records = [
            json.loads(r) for r in (opcua_setup.state / "audit.jsonl").read_text().splitlines()
        ]
        mine = [(r["who"], r["what"], r["outcome"]) for r in records if r["face"] == "opcua"]
        assert any(w == "olga" and "SetSpeed" in what and o == "ok" for w, what, o in mine)
        assert ("vic", "SpeedOverride(channel=1)", "refused: not an operator") in mine
        assert any(w == "olga" and "150" in o for w, _, o in mine)

    asyncio.run(main())
