"""The Modbus face's reads, with pymodbus's client as the PLC against the simulator through
the line server: every block of the map shows what the line's model holds, with its age and
quality; values are flagged when the line drops; the PLC's polling never reaches the line."""

from __future__ import annotations

import asyncio
import struct
from pathlib import Path

from robostar.serve.faces.modbus.layout import (
    BLOCKS,
    DI,
    IR,
    MAP_VERSION,
    Quality,
    channel_base,
)

from .conftest import cell, text_of, until


def _float(words: list[int]) -> float:
    return float(struct.unpack(">f", struct.pack(">HH", *words))[0])


def _int32(words: list[int]) -> int:
    return int(struct.unpack(">i", struct.pack(">HH", *words))[0])


def _health(registers: list[int], name: str) -> tuple[int, int]:
    block = next(b for b in BLOCKS if b.name == name)
    at = IR.HEALTH + 2 * block.index
    return registers[at], registers[at + 1]


def test_every_block_reads_as_the_model_holds_it(tmp_path: Path) -> None:
    async def main() -> None:
        options = {
            "globals": {"int": {"first": 3, "count": 2}, "float": {"first": 5, "count": 1}},
            "globals_interval": 0.1,
        }
        sim_values = {"ints": {3: -70000, 4: 12}, "floats": {5: 2.5}}
        async with cell(tmp_path, **options) as c:
            model = c.sim.model
            model.ints.update(sim_values["ints"])
            model.floats.update(sim_values["floats"])
            model.inputs[1][3] = True
            model.outputs[0][15] = True
            c.sim.controller.model.raise_alarm(1153, 1, "")
            await c.line.wait_polled()
            await c.line.wait_polled()

            async def globals_read() -> bool:
                ints = await c.input_registers(IR.GLOBAL_INTS, 4)
                return _int32(ints[0:2]) == -70000

            await until(globals_read)
            header = await c.input_registers(0, IR.HEALTH + 2 * len(BLOCKS))
            assert header[IR.MAP_VERSION] == MAP_VERSION
            assert header[IR.ONLINE] == 1
            assert header[IR.INT_FIRST : IR.FLOAT_COUNT + 1] == [3, 2, 5, 1]
            # (ch1.step is not asked for: the controller refuses ED while no job is selected)
            for name in ("ch1.status", "ch1.position", "ch1.angles", "ch1.speed", "ch1.job"):
                quality, age = _health(header, name)
                assert quality == Quality.GOOD, name
                assert age < 65535, name
            for name in ("alarms", "inputs", "outputs", "global_ints", "global_floats"):
                assert _health(header, name)[0] == Quality.GOOD, name
            assert _health(header, "ch3.status")[0] == Quality.NOT_IN_USE  # no robot there

            snapshot = c.line.model.snapshot()
            base = channel_base(1)
            ch1 = await c.input_registers(base, 40)
            status = snapshot["ch1/status"].value
            assert ch1[IR.STATUS] == sum(
                1 << bit for bit, name in enumerate(DI.STATUS_BITS) if getattr(status, name)
            )
            assert ch1[IR.SPEED] == snapshot["ch1/speed"].value
            position = snapshot["ch1/position"].value
            assert ch1[IR.XY_AXES] == len(position.axes)
            for i, value in enumerate(position.axes):
                at = IR.XY + 2 * i
                assert abs(_float(ch1[at : at + 2]) - value) < 1e-3
            angles = snapshot["ch1/angles"].value
            for i, value in enumerate(angles.axes):
                at = IR.ANGLES + 2 * i
                assert abs(_float(ch1[at : at + 2]) - value) < 1e-3

            alarms = await c.input_registers(IR.ALARM_COUNT, 9)
            assert alarms[0] >= 1 and 1153 in alarms[1:]
            io = await c.input_registers(IR.INPUTS, 10)
            assert io[1] == 1 << 3 and io[5] == 1 << 15
            model.inputs[2][0] = True  # port 2 is not polled: it reads 0, and the map says so
            await c.line.wait_polled()
            await c.line.wait_polled()
            (polled,) = await c.input_registers(IR.IO_POLLED, 1)
            assert polled == 0b00011  # the cell polls ports 0 and 1
            assert (await c.input_registers(IR.INPUTS + 2, 1)) == [0]
            ints = await c.input_registers(IR.GLOBAL_INTS, 4)
            assert [_int32(ints[0:2]), _int32(ints[2:4])] == [-70000, 12]
            floats = await c.input_registers(IR.GLOBAL_FLOATS, 2)
            assert _float(floats) == 2.5

            bits = (await c.plc.read_discrete_inputs(0, count=DI.SIZE)).bits
            assert bits[DI.ONLINE] is True
            for bit, name in enumerate(DI.STATUS_BITS):
                assert bits[bit] is getattr(c.line.model.get("ch1/status").value, name), name
            assert bits[DI.STATUS_GOOD] is True
            assert bits[DI.INPUTS + 16 * 1 + 3] is True
            assert bits[DI.OUTPUTS + 15] is True

    asyncio.run(main())


def test_the_selected_job_shows_its_name_and_number(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path) as c:
            from robostar.commands.job import SelectJob
            from robostar.serve.lease import Who

            c.sim.model.channel(1).origin = True  # homed: DC takes a JOB only then
            await c.line.execute(SelectJob(1, "DEMO.JOB"), who=Who("t", "cli"), implicit_lease=True)
            base = channel_base(1)

            async def shown() -> bool:
                ch1 = await c.input_registers(base, 10)
                return ch1[IR.JOB_NUMBER] == 1 and text_of(ch1[IR.JOB_NAME : IR.JOB_NAME + 6]) == (
                    "DEMO.JOB"
                )

            await until(shown, timeout=10)

    asyncio.run(main())


def test_values_are_flagged_when_the_line_drops(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path) as c:
            header = await c.input_registers(0, IR.HEALTH + 2 * len(BLOCKS))
            assert header[IR.NOT_GOOD : IR.NOT_GOOD + 2] == [0, 0]
            c.sim.broken = True
            await until(lambda: not c.line.up)
            header = await c.input_registers(0, IR.HEALTH + 2 * len(BLOCKS))
            assert header[IR.ONLINE] == 0
            assert header[IR.NOT_GOOD : IR.NOT_GOOD + 2] != [0, 0]
            for name in ("ch1.status", "ch1.position", "alarms", "inputs"):
                assert _health(header, name)[0] == Quality.LINE_DOWN, name
            bits = (await c.plc.read_discrete_inputs(0, count=DI.SIZE)).bits
            assert bits[DI.ONLINE] is False
            assert bits[DI.STATUS_GOOD] is False
            c.sim.broken = False
            await until(lambda: c.line.up)
            await c.line.wait_polled()
            await c.line.wait_polled()
            header = await c.input_registers(0, IR.HEALTH + 2 * len(BLOCKS))
            assert header[IR.ONLINE] == 1
            assert _health(header, "ch1.status")[0] == Quality.GOOD

    asyncio.run(main())


def test_the_plcs_polling_does_not_reach_the_line(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path) as c:
            before = c.line.health.exchanges
            for _ in range(200):
                await c.input_registers(0, 125)
                await c.plc.read_discrete_inputs(0, count=DI.SIZE)
            polls = c.line.health.exchanges - before
            # the poller's own cycles only (each a handful of exchanges): 400 reads would be 400+
            assert polls < 400, polls

    asyncio.run(main())
