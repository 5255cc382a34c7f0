"""A face's one-shot command (``implicit_lease=True``: one MQTT command, a click) takes a free
lease for that command only and gives it back as it ends, success or not, so it never locks the
cell's N1 host program out; a jog started so keeps it until its stop; an N1 host program holds
the lease between its writes; a lease another holds refuses a one-shot command as before."""

from __future__ import annotations

import asyncio

import pytest

from robostar.client.aio import AsyncClient
from robostar.commands.control import SetSpeed
from robostar.commands.motion import JogContinue, JogStart, JogStop
from robostar.commands.variables import WriteGlobalInt
from robostar.errors import RobostarError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.lease import LeaseHeldError, Who
from robostar.types import JogDirection, MotionType

MQTT = Who("mqtt-client", "mqtt")
WEB = Who("olga", "web")


def _config() -> ServeConfig:
    return ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.5),),
        faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
    )


def test_a_one_shot_command_gives_the_lease_back_and_the_n1_host_writes_at_once() -> None:
    async def main() -> None:
        async with LineServer(_config()) as server:
            line = server.lines["cell1"]
            await line.execute(SetSpeed(1, 40), who=MQTT, implicit_lease=True)  # cmd/speed
            assert line.lease.holder is None
            host, port = server.faces["n1"].addresses["cell1"]
            async with AsyncClient(f"tcp://{host}:{port}") as n1:
                await n1.execute(WriteGlobalInt(7, 1234))  # not refused: 0x32
                holder = line.lease.holder
                # the host program keeps control between its writes (a sequence)
                assert holder is not None and holder.who.face == "n1" and not holder.once
                with pytest.raises(LeaseHeldError, match=r"\(n1\)"):
                    await line.execute(SetSpeed(1, 50), who=MQTT, implicit_lease=True)

    asyncio.run(main())


def test_a_one_shot_lease_is_given_back_when_its_command_fails() -> None:
    async def main() -> None:
        async with LineServer(_config()) as server:
            line = server.lines["cell1"]
            with pytest.raises(RobostarError):
                # channel 9 has no robot: the controller refuses it
                await line.execute(SetSpeed(9, 40), who=MQTT, implicit_lease=True)
            assert line.lease.holder is None

    asyncio.run(main())


def test_a_one_shot_jog_keeps_the_lease_until_it_stops() -> None:
    async def main() -> None:
        async with LineServer(_config()) as server:
            line = server.lines["cell1"]
            start = JogStart(1, 1, JogDirection.PLUS, MotionType.JOINT)
            await line.execute(start, who=WEB, implicit_lease=True)
            holder = line.lease.holder
            assert holder is not None and holder.who == WEB and holder.once
            await line.execute(JogContinue(1), who=WEB, implicit_lease=True)
            assert line.lease.held_by(WEB)
            with pytest.raises(LeaseHeldError, match="olga"):
                await line.execute(SetSpeed(1, 40), who=MQTT, implicit_lease=True)
            await line.execute(JogStop(1), who=WEB, implicit_lease=True)
            assert line.lease.holder is None

    asyncio.run(main())


def test_an_explicit_take_is_kept_past_a_one_shot_command_of_its_holder() -> None:
    async def main() -> None:
        async with LineServer(_config()) as server:
            line = server.lines["cell1"]
            line.lease.acquire(WEB, 300)  # "Take control"
            await line.execute(SetSpeed(1, 40), who=WEB, implicit_lease=True)
            assert line.lease.held_by(WEB)
            with pytest.raises(LeaseHeldError, match="olga"):
                await line.execute(SetSpeed(1, 45), who=MQTT, lease="hold")

    asyncio.run(main())
