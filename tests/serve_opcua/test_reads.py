"""OPC UA Read's maxAge: 0 (asyncua's and most clients' default) reads the line and shows its
answer with the time it was read; a larger maxAge the model meets is answered from the model,
with the sample's own source timestamp, without a line exchange; variables answered by one
command cost one exchange per Read; subscriptions keep publishing the model."""

from __future__ import annotations

import asyncio
import datetime as dt
import time
from typing import Any

import pytest

from .conftest import Model, Setup, connect, read_values, serving

pytestmark = pytest.mark.timeout(120)

HOUR_MS = 3_600_000.0


def test_max_age_zero_reads_the_line_and_a_larger_one_the_model(opcua_setup: Setup) -> None:
    async def main() -> None:
        # a slow poller (the speed is read in its slow cycle): the model keeps what the test
        # puts in it, as a sample taken earlier
        async with (
            serving(opcua_setup, poll=100.0, slow=100.0) as server,
            connect(server, opcua_setup) as client,
        ):
            line = server.line("cell1")
            face: Any = server.faces["opcua"]
            speed = await Model(client).path(
                "rob:MotionDevices", "ven:Channel1", "di:ParameterSet", "rob:SpeedOverride"
            )
            (now,) = await read_values(client, [speed], 0)
            real = now.Value.Value
            line.model.set("ch1/speed", 777)  # what the model holds: not the controller's
            sample = line.model.get("ch1/speed")
            assert sample is not None
            await asyncio.sleep(0.05)

            reads = face.reads.line_reads
            (old,) = await read_values(client, [speed], HOUR_MS)
            assert old.Value.Value == 77.7  # the model's, as accepted
            assert abs(_seconds(old.SourceTimestamp) - sample.at) < 0.001  # the sample's time
            assert face.reads.line_reads == reads  # no exchange

            asked = time.time()
            (fresh,) = await read_values(client, [speed], 0)
            assert fresh.Value.Value == real  # the controller's answer
            assert _seconds(fresh.SourceTimestamp) >= asked - 0.001  # read after it was asked
            assert face.reads.line_reads == reads + 1

            # a maxAge younger than the sample: the line again
            await asyncio.sleep(0.05)
            (younger,) = await read_values(client, [speed], 10.0)
            assert younger.Value.Value == real
            assert face.reads.line_reads == reads + 2

    asyncio.run(main())


def test_one_exchange_answers_every_variable_of_one_command(opcua_setup: Setup) -> None:
    async def main() -> None:
        async with (
            serving(opcua_setup, poll=30.0) as server,
            connect(server, opcua_setup) as client,
        ):
            face: Any = server.faces["opcua"]
            model = Model(client)
            names = ("OriginDone", "InPosition", "Ready", "Running", "Alarm")
            nodes = [
                await model.path("rob:MotionDevices", "ven:Channel1", "ven:Robostar", f"ven:{n}")
                for n in names
            ]
            reads = face.reads.line_reads
            values = await read_values(client, nodes, 0)
            assert all(v.StatusCode.is_good() for v in values)
            assert face.reads.line_reads == reads + 1  # one AA for the five status bits

    asyncio.run(main())


def _seconds(moment: dt.datetime) -> float:
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=dt.UTC)
    return moment.timestamp()
