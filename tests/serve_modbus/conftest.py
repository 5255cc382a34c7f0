"""Helpers of the Modbus face tests: a line server in front of the in-process simulator (with a
cable the test can pull), its Modbus face on a free loopback port, pymodbus's client as the PLC."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable, Sequence
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pymodbus.client import AsyncModbusTcpClient

from robostar.client.aio import AsyncClient
from robostar.client.exchange import Progress
from robostar.commands.base import Command
from robostar.errors import OutcomeUnknownError, PortError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.modbus.layout import HR
from robostar.serve.line import Line
from robostar.sim import SimConfig, VirtualController
from robostar.transport.inproc import AsyncPeerTransport

PRIMED = 65535
"""The sequence number :func:`cell` writes first when commands are enabled."""


class Sim:
    """The simulator behind the line, and a cable to pull (``broken``)."""

    def __init__(self) -> None:
        self.controller = VirtualController(SimConfig())
        self.broken = False
        self.lose_answer_of: str | None = None
        """A command code whose answer is lost after the controller carried it out."""

    def client(self, config: LineConfig) -> AsyncClient:
        sim = self

        class Client(AsyncClient):
            async def execute(self, command: Command[Any], progress: Progress | None = None) -> Any:
                result = await super().execute(command, progress)
                if sim.lose_answer_of == command.CODE:
                    raise OutcomeUnknownError(command.CODE, "the answer was lost")
                return result

        class Cable(AsyncPeerTransport):
            async def open(self) -> None:
                if sim.broken:
                    raise PortError("cable pulled")
                await super().open()

            async def write(self, data: bytes) -> None:
                if sim.broken:
                    raise PortError("cable pulled")
                await super().write(data)

        return Client(Cable(self.controller, url="sim://"), timeout=0.5)

    @property
    def model(self) -> Any:
        return self.controller.model


@dataclass
class Cell:
    server: LineServer
    line: Line
    plc: AsyncModbusTcpClient
    sim: Sim
    audit: Path

    async def command(self, code: int, *params: int, sequence: int) -> list[int]:
        """Write a command block (code, parameters, then the sequence, in one write) and wait
        until the face publishes that sequence as finished: the result registers."""
        block = [code, *params, *[0] * (HR.PARAM_COUNT - len(params)), sequence]
        await self.write_block(block)
        return await self.result(sequence)

    async def write_block(self, block: Sequence[int]) -> None:
        answer = await self.plc.write_registers(HR.COMMAND, list(block))
        assert not answer.isError(), answer

    async def result(self, sequence: int) -> list[int]:
        """The result registers once HR.DONE_SEQUENCE says ``sequence`` (from HR.WRITABLE)."""
        for _ in range(500):
            answer = await self.plc.read_holding_registers(HR.WRITABLE, count=HR.SIZE - HR.WRITABLE)
            assert not answer.isError(), answer
            if answer.registers[0] == sequence:
                return list(answer.registers)
            await asyncio.sleep(0.01)
        raise AssertionError(f"sequence {sequence} never finished: {answer.registers}")

    async def input_registers(self, address: int, count: int) -> list[int]:
        answer = await self.plc.read_input_registers(address, count=count)
        assert not answer.isError(), answer
        return list(answer.registers)


def text_of(words: Sequence[int]) -> str:
    return b"".join(w.to_bytes(2, "big") for w in words).rstrip(b"\0").decode("ascii")


async def until(predicate: Callable[[], Any], timeout: float = 5.0) -> None:
    """Wait (polling every 10 ms) until ``predicate()`` holds; AssertionError after ``timeout``."""
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while True:
        result = predicate()
        if asyncio.iscoroutine(result):
            result = await result
        if result:
            return
        if loop.time() >= end:
            raise AssertionError("the condition did not come")
        await asyncio.sleep(0.01)


@asynccontextmanager
async def cell(tmp_path: Path, *, prime: bool = True, **options: Any) -> AsyncIterator[Cell]:
    """A line server (line cell1 on the simulator, auditing to a file) with its Modbus face on
    a free loopback port, ``options`` added to the ``[modbus]`` section, and a PLC connected
    (that has written its first sequence number, :data:`PRIMED`, when commands are enabled
    and ``prime``)."""
    sim = Sim()
    audit = tmp_path / "audit.jsonl"
    config = ServeConfig(
        lines=(
            LineConfig("cell1", "sim://", poll_interval=0.05, slow_interval=0.1, io_ports=(0, 1)),
        ),
        faces={"modbus": {"lines": {"cell1": "127.0.0.1:0"}, **options}},
        audit_path=str(audit),
    )
    async with LineServer(config, client_factory=sim.client) as server:
        line = server.line("cell1")
        await line.wait_polled()
        await line.wait_polled()  # a slow cycle too (speed, job, I/O)
        host, port = server.faces["modbus"].addresses["cell1"]  # type: ignore[attr-defined]
        plc = AsyncModbusTcpClient(host, port=port, timeout=3)
        await plc.connect()
        try:
            c = Cell(server, line, plc, sim, audit)
            if prime and options.get("commands", {}).get("enabled"):
                # the first sequence number after a start is a baseline, never run (reason
                # restarted): a PLC's first write, as after every start of the face
                await c.write_block([0] * HR.SEQUENCE + [PRIMED])
                await c.result(PRIMED)
            yield c
        finally:
            plc.close()
