"""A host program through the line server sees the robot as it is, as it would on the
controller's own port: after a move it waited for, the position read is the one the move
reached; after a move the controller refused (soft limits), the status and the alarm list show
the alarm it raised. Through the N1 face and through serve://, with a second consumer polling
status on its own connection (as a dashboard or another cell PC does)."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import pytest

from robostar import AsyncClient
from robostar.errors import ControllerError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.sim import SimConfig, VirtualController
from robostar.sim.alarms import AlarmCode

from .line_fakes import FaultySim

ROUNDS = 12
STEP = 1.5


@asynccontextmanager
async def _cell(way: str) -> AsyncIterator[str]:
    """A line server in front of a (10x fast) simulator, polling as a plant's would; the URL
    a host uses to reach its line ``way`` ("n1": the N1 face, "serve": serve://)."""
    sim = FaultySim()
    sim.controller = VirtualController(SimConfig(speedup=10.0))
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.05, slow_interval=0.1),),
        faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}, "api": {"listen": "127.0.0.1:0"}},
    )
    async with LineServer(config, client_factory=sim.client) as server:
        if way == "n1":
            host, port = server.faces["n1"].addresses["cell1"]  # type: ignore[attr-defined]
            yield f"tcp://{host}:{port}"
        else:
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            yield f"serve://{host}:{port}/cell1"


@asynccontextmanager
async def _someone_polling(url: str) -> AsyncIterator[None]:
    """A second consumer reading status and positions as fast as it can, on its own link."""

    async def poll() -> None:
        async with AsyncClient(url) as other:
            while True:
                await other.status()
                await other.position(1, "angle")

    task = asyncio.create_task(poll())
    try:
        yield
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task


async def _wait_in_position(host: AsyncClient) -> None:
    """What host programs do: AA until the channel is in position and not running."""
    while True:
        status = (await host.status())[0]
        if status.in_position and not status.running:
            return
        await asyncio.sleep(0.005)


@pytest.mark.parametrize("way", ["n1", "serve"])
def test_the_position_after_a_move_waited_for_is_the_one_it_reached(way: str) -> None:
    async def main() -> list[float]:
        async with _cell(way) as url, _someone_polling(url), AsyncClient(url) as host:
            await host.home(1, wait=True)
            moved = []
            for _ in range(ROUNDS):
                before = (await host.position(1, "angle")).axes[0]
                await host.move_by(1, (STEP, 0.0, 0.0, 0.0))
                await asyncio.sleep(0.02)
                await _wait_in_position(host)
                moved.append((await host.position(1, "angle")).axes[0] - before)
            return moved

    moved = asyncio.run(main())
    wrong = [delta for delta in moved if delta != pytest.approx(STEP, abs=0.01)]
    assert not wrong, f"{len(wrong)} of {len(moved)} rounds read a position not reached: {wrong}"


@pytest.mark.parametrize("way", ["n1", "serve"])
def test_a_refused_moves_alarm_is_seen_by_the_next_status_read(way: str) -> None:
    async def main() -> list[tuple[bool, list[int]]]:
        async with _cell(way) as url, _someone_polling(url), AsyncClient(url) as host:
            await host.home(1, wait=True)
            seen = []
            for _ in range(ROUNDS):
                with pytest.raises(ControllerError):
                    await host.move(1, (150.0, 0.0, 0.0, 0.0))  # past axis 1's soft limits
                status = (await host.status())[0]
                alarms = [alarm.code for alarm in await host.alarms()]
                seen.append((status.alarm, alarms))
                await host.reset_alarms()
                await asyncio.sleep(0.03)  # the other consumer's reads refresh the model
            return seen

    seen = asyncio.run(main())
    missed = [s for s in seen if not (s[0] and s[1] == [AlarmCode.SOFT_LIMIT])]
    assert not missed, f"{len(missed)} of {len(seen)} rounds missed alarm 9003: {missed}"
