"""The map between two polls: the face rebuilds its values only when the model changed, yet
the ages keep moving and a quality change (a value marked stale, which stores nothing) shows
at the next read."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path

from pymodbus.client import AsyncModbusTcpClient

from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.modbus.layout import BLOCKS, IR, Quality


def test_ages_move_and_a_stale_mark_shows_between_polls(tmp_path: Path) -> None:
    status = next(b for b in BLOCKS if b.name == "ch1.status")
    quality_at, age_at = IR.HEALTH + 2 * status.index, IR.HEALTH + 2 * status.index + 1

    async def main() -> None:
        config = ServeConfig(
            lines=(LineConfig("cell1", "sim://", poll_interval=30.0, slow_interval=30.0),),
            faces={"modbus": {"lines": {"cell1": "127.0.0.1:0"}}},
        )
        async with LineServer(config) as server:
            line = server.line("cell1")
            await line.wait_polled()
            host, port = server.faces["modbus"].addresses["cell1"]  # type: ignore[attr-defined]
            plc = AsyncModbusTcpClient(host, port=port, timeout=3)
            await plc.connect()
            try:
                first = (await plc.read_input_registers(0, count=60)).registers
                await asyncio.sleep(0.3)
                updates = line.model.updates
                second = (await plc.read_input_registers(0, count=60)).registers
                assert line.model.updates == updates  # nothing was polled in between
                assert first[quality_at] == second[quality_at] == Quality.GOOD
                assert second[age_at] >= first[age_at] + 250
                line.model.age_out(math.inf, keep=("online", "info"))
                third = (await plc.read_input_registers(0, count=60)).registers
                assert line.model.updates == updates
                assert third[quality_at] == Quality.STALE
                assert third[IR.NOT_GOOD : IR.NOT_GOOD + 2] != [0, 0]
            finally:
                plc.close()

    asyncio.run(main())
