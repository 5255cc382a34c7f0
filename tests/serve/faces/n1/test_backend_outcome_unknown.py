"""A state change whose outcome the line cannot tell (its answer was lost: it may have run) reaches
an N1 host as a controller that cannot say would give it: the exchange ends with RST, never flag
0x32 "function failed", so a host program that retries on failure does not send it twice."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from tests.serve.line_fakes import FaultySim

from robostar import Client
from robostar.client.aio import AsyncClient
from robostar.commands.base import Command
from robostar.commands.control import ReadSpeed, SetSpeed
from robostar.commands.system import ReadLastError
from robostar.errors import FunctionFailedError, OutcomeUnknownError
from robostar.serve import LineConfig, LineServer, ServeConfig


def _loses_setspeed_answers(sim: FaultySim) -> None:
    def fault(command: Command[Any]) -> BaseException | None:
        if isinstance(command, SetSpeed):  # the controller carried it out; its answer was lost
            return OutcomeUnknownError(command.CODE, "no answer within 2 s")
        return None

    sim.after.append(fault)


def _config() -> ServeConfig:
    return ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.5),),
        faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
    )


def test_an_unknown_outcome_reaches_an_async_host_as_unknown_not_as_failed() -> None:
    sim = FaultySim()
    _loses_setspeed_answers(sim)

    async def main() -> tuple[int, str, int]:
        async with LineServer(_config(), client_factory=sim.client) as server:
            host, port = server.faces["n1"].addresses["cell1"]
            async with AsyncClient(f"tcp://{host}:{port}", timeout=3.0) as host_program:
                with pytest.raises(OutcomeUnknownError):
                    await host_program.execute(SetSpeed(1, 444))
                # the session goes on: KD says why, and the next request is answered
                why = await host_program.execute(ReadLastError())
                speed = await host_program.execute(ReadSpeed(1))
            return await server.lines["cell1"].read(ReadSpeed(1), max_age=0), why, speed

    on_line, why, speed = asyncio.run(main())
    assert on_line == 444 and speed == 444  # it was carried out
    assert "outcome is unknown" in why
    assert sum(isinstance(c, SetSpeed) for c in sim.sent) == 1


def test_an_unknown_outcome_reaches_a_sync_client_as_unknown_not_as_failed() -> None:
    sim = FaultySim()
    _loses_setspeed_answers(sim)

    def host_program(url: str) -> BaseException | None:
        with Client(url, timeout=3.0) as robot:
            try:
                robot.execute(SetSpeed(1, 445))
            except (OutcomeUnknownError, FunctionFailedError) as exc:
                return exc
        return None

    async def main() -> BaseException | None:
        async with LineServer(_config(), client_factory=sim.client) as server:
            host, port = server.faces["n1"].addresses["cell1"]
            return await asyncio.to_thread(host_program, f"tcp://{host}:{port}")

    error = asyncio.run(main())
    assert isinstance(error, OutcomeUnknownError), repr(error)
