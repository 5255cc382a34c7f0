"""A channel's configured label is what people read (DisplayName, ComponentName), never part of
a browse path: clients' paths name ``Channel<n>`` whatever the channel is called, so renaming a
channel in the configuration breaks no SCADA tag. A configured channel the controller does not
have is not shown."""

from __future__ import annotations

import asyncio

import pytest

from .conftest import Model, Setup, connect, serving

pytestmark = pytest.mark.timeout(120)


def test_a_labelled_channel_keeps_its_browse_name(opcua_setup: Setup) -> None:
    async def main() -> None:
        labels = {1: "loader", 2: "unloader"}
        async with (
            serving(opcua_setup, channels=labels) as server,
            connect(server, opcua_setup) as client,
        ):
            model = Model(client)
            # docs/opcua.md's browse example, unchanged by the labels
            position = await model.axis_position(1, 1)
            assert isinstance(await position.read_value(), float)
            for channel, label in labels.items():
                device = await model.path("rob:MotionDevices", f"ven:Channel{channel}")
                assert (await device.read_display_name()).Text == label
                name = await model.path(
                    "rob:MotionDevices", f"ven:Channel{channel}", "di:ComponentName"
                )
                assert (await name.read_value()).Text == f"cell1 {label}"
                task = await model.path(
                    "rob:Controllers", "ven:cell1", "rob:TaskControls", f"ven:Channel{channel}"
                )
                assert (await task.read_display_name()).Text == label
            machine = await model.state_machine(1)
            assert {(await m.read_browse_name()).Name for m in await machine.get_methods()} >= {
                "Start"
            }

    asyncio.run(main())


def test_an_unlabelled_channel_is_shown_by_its_number(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            device = await Model(client).path("rob:MotionDevices", "ven:Channel1")
            assert (await device.read_display_name()).Text == "Channel1"

    asyncio.run(main())


def test_a_configured_channel_the_controller_lacks_is_not_shown(opcua_setup: Setup) -> None:
    async def main() -> None:
        # the simulator has channels 1 and 2
        async with (
            serving(opcua_setup, channels={1: "loader", 3: "nowhere"}) as server,
            connect(server, opcua_setup) as client,
        ):
            devices = await Model(client).path("rob:MotionDevices")
            names = [(await d.read_browse_name()).Name for d in await devices.get_children()]
            assert names == ["Channel1"]

    asyncio.run(main())
