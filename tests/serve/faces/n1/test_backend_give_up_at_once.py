"""A host that gives its request up at once — its RST (or its next request) in the same read as
the request, or read before the line server's task for it has run — has its write withdrawn:
nothing is sent, and the audit says so: a giving-up that arrives in the same read as the request
is told to the backend as well as one held after the turn began, and a withdraw that comes before
the request is queued still finds it."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from tests.serve.line_fakes import FaultySim, hold_the_line, n1_server

from robostar.commands.control import SetSpeed
from robostar.controller_role import ControllerSession
from robostar.protocol.frame import RST, encode_packet
from robostar.serve import LineConfig
from robostar.serve.faces.n1.backend import N1Backend
from robostar.serve.line import Line

pytestmark = pytest.mark.timeout(30)


def test_request_and_rst_in_one_write_over_the_n1_face(tmp_path: Path) -> None:
    sim = FaultySim()
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with n1_server(sim, audit) as (line, host, port):
            busy = await hold_the_line(line, sim)
            _, writer = await asyncio.open_connection(host, port)
            writer.write(encode_packet(SetSpeed(1, 562).encode()) + bytes([RST]))
            await writer.drain()
            await busy
            sim.write_delay = 0.0
            await asyncio.sleep(0.5)
            writer.close()

    asyncio.run(main())
    assert [c.speed for c in sim.sent if isinstance(c, SetSpeed)] == []
    entries = [json.loads(line) for line in audit.read_text().splitlines()]
    outcomes = [e["outcome"] for e in entries if "SetSpeed" in e["what"]]
    assert outcomes and all(o.startswith("cancelled, not sent") for o in outcomes), outcomes


@pytest.mark.parametrize("separate_reads", [True, False], ids=["later read", "same read"])
def test_a_give_up_before_the_task_ran_withdraws_the_write(separate_reads: bool) -> None:
    sim = FaultySim()

    async def main() -> None:
        config = LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0)
        line = Line(config, client_factory=sim.client)
        await line.start()
        try:
            await line.wait_polled()
            busy = await hold_the_line(line, sim)
            session = ControllerSession(N1Backend(line), name="h1")
            now = asyncio.get_running_loop().time()
            request = encode_packet(SetSpeed(1, 561).encode())
            if separate_reads:
                session.feed(request, now)
                session.feed(bytes([RST]), now)  # before the backend's task has run
            else:
                session.feed(request + bytes([RST]), now)
            await busy
            sim.write_delay = 0.0
            await asyncio.sleep(0.5)
        finally:
            await line.stop()

    asyncio.run(main())
    assert [c.speed for c in sim.sent if isinstance(c, SetSpeed)] == []
