"""What a PLC gets for a request the map does not take: the Modbus exception it expects
(ILLEGAL DATA ADDRESS, ILLEGAL DATA VALUE), never silence, and nothing reaches the line."""

from __future__ import annotations

import asyncio
from pathlib import Path

from robostar.serve.faces.modbus.layout import DI, HR, IR

from .conftest import cell

ILLEGAL_ADDRESS, ILLEGAL_VALUE = 2, 3


def test_unmapped_and_read_only_addresses_are_illegal(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ["servo"]}) as c:
            plc = c.plc
            answers = {
                "coil read": await plc.read_coils(0, count=1),
                "coil write": await plc.write_coil(0, True),
                "input registers past the end": await plc.read_input_registers(
                    IR.SIZE - 1, count=2
                ),
                "discrete inputs past the end": await plc.read_discrete_inputs(DI.SIZE, count=1),
                "holding registers past the end": await plc.read_holding_registers(
                    HR.SIZE, count=1
                ),
                "a result register": await plc.write_register(HR.DONE_SEQUENCE, 5),
                "the results": await plc.write_registers(HR.SEQUENCE, [1, 2]),
                "past the end": await plc.write_register(HR.SIZE + 3, 1),
            }
            for what, answer in answers.items():
                assert answer.isError(), what
                assert answer.exception_code == ILLEGAL_ADDRESS, (what, answer)
            answer = await plc.write_register(HR.COMMAND, 999)  # no such command code
            assert answer.isError() and answer.exception_code == ILLEGAL_VALUE, answer
            assert c.sim.controller.executions == {}

    asyncio.run(main())


def test_writes_are_refused_unless_enabled(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path) as c:
            block = [5, 1, 1, 0, 0, 0, 0, 0, 0, 1]  # servo on, sequence 1
            answer = await c.plc.write_registers(HR.COMMAND, block)
            assert answer.isError() and answer.exception_code == ILLEGAL_ADDRESS, answer
            answer = await c.plc.write_register(HR.SEQUENCE, 1)
            assert answer.isError() and answer.exception_code == ILLEGAL_ADDRESS, answer
            read = await c.plc.read_holding_registers(HR.COMMAND, count=HR.SIZE)
            assert not read.isError() and read.registers[HR.SEQUENCE] == 0
            await c.line.wait_polled()
            assert c.sim.controller.executions == {}

    asyncio.run(main())
