"""An N1 session's requests still in the line's queue are withdrawn (nothing sent) when its
connection closes or its host gives the exchange up: a write of a host that moved on or left never
reaches the robot, least of all under someone else's lease."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

from tests.serve.line_fakes import FaultySim, hold_the_line, n1_server, wait_for

from robostar.commands.control import ReadSpeed, SetSpeed
from robostar.controller_role import ControllerSession
from robostar.protocol.frame import RST, encode_packet
from robostar.serve import LineConfig, Who
from robostar.serve.faces.n1.backend import N1Backend
from robostar.serve.line import Line

ANN = Who("ann", "api")


def _n1_outcomes(path: Path, what: str) -> list[str]:
    entries = [json.loads(raw) for raw in path.read_text().splitlines()]
    return [e["outcome"] for e in entries if e["face"] == "n1" and what in e["what"]]


def test_a_write_of_a_host_that_disconnected_never_runs_under_another_lease(
    tmp_path: Path,
) -> None:
    sim = FaultySim()
    path = tmp_path / "audit.jsonl"

    async def main() -> int:
        async with n1_server(sim, path) as (line, host, port):
            busy = await hold_the_line(line, sim)
            _, writer = await asyncio.open_connection(host, port)
            writer.write(encode_packet(SetSpeed(1, 555).encode()))
            await writer.drain()
            assert await wait_for(lambda: line.lease.holder is not None)  # queued, leased
            writer.close()  # the host program goes away
            assert await wait_for(lambda: line.lease.holder is None)
            line.lease.acquire(ANN)  # the engineer now holds control
            await busy
            sim.write_delay = 0.0
            await asyncio.sleep(0.2)  # the worker would have sent it by now
            return await line.read(ReadSpeed(1), max_age=0)

    assert asyncio.run(main()) != 555
    assert not any(isinstance(c, SetSpeed) for c in sim.sent)
    (outcome,) = _n1_outcomes(path, "SetSpeed")
    assert outcome.startswith("cancelled, not sent: ")
    assert "its N1 connection closed" in outcome


def test_a_request_whose_connection_closed_before_it_was_served_is_never_queued() -> None:
    sim = FaultySim()

    async def main() -> None:
        config = LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0)
        line = Line(config, client_factory=sim.client)
        await line.start()
        try:
            await line.wait_polled()
            backend = N1Backend(line)
            session = ControllerSession(backend, name="h1")
            loop = asyncio.get_running_loop()
            session.feed(encode_packet(SetSpeed(1, 559).encode()), loop.time())
            session.close()  # the connection drops before the backend's task has run
            await asyncio.sleep(0.2)
            assert line.lease.holder is None  # not taken for a session already gone
        finally:
            await line.stop()

    asyncio.run(main())
    assert not any(isinstance(c, SetSpeed) for c in sim.sent)


def test_a_write_whose_host_gave_the_exchange_up_is_withdrawn(tmp_path: Path) -> None:
    sim = FaultySim()
    path = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with n1_server(sim, path) as (line, host, port):
            busy = await hold_the_line(line, sim)
            _, writer = await asyncio.open_connection(host, port)
            writer.write(encode_packet(SetSpeed(1, 556).encode()))
            await writer.drain()
            assert await wait_for(lambda: line.lease.holder is not None)  # queued
            writer.write(bytes([RST]))  # the host gives up waiting; the connection stays
            await writer.drain()
            assert await wait_for(lambda: bool(_n1_outcomes(path, "SetSpeed")))
            await busy
            sim.write_delay = 0.0
            await asyncio.sleep(0.2)  # the worker would have sent it by now
            writer.close()

    asyncio.run(main())
    assert not any(isinstance(c, SetSpeed) for c in sim.sent)
    (outcome,) = _n1_outcomes(path, "SetSpeed")
    assert outcome.startswith("cancelled, not sent: ")
    assert "gave the exchange up" in outcome


def test_a_new_request_of_the_same_host_withdraws_the_one_it_superseded(tmp_path: Path) -> None:
    sim = FaultySim()
    path = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with n1_server(sim, path) as (line, host, port):
            busy = await hold_the_line(line, sim)
            _, writer = await asyncio.open_connection(host, port)
            writer.write(encode_packet(SetSpeed(1, 557).encode()))
            await writer.drain()
            assert await wait_for(lambda: line.lease.holder is not None)
            writer.write(encode_packet(SetSpeed(1, 58).encode()))  # it moved on
            await writer.drain()
            await busy
            sim.write_delay = 0.0
            assert await wait_for(lambda: len(_n1_outcomes(path, "SetSpeed")) == 2)
            writer.close()

    asyncio.run(main())
    assert [c.speed for c in sim.sent if isinstance(c, SetSpeed)] == [58]
    first, second = _n1_outcomes(path, "SetSpeed")
    assert first.startswith("cancelled, not sent: ") and "gave the exchange up" in first
    assert second == "ok"
