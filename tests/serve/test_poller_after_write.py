"""After a state change the poller reads again at once what it may have changed: a narrow one
(a speed, a global variable) only that, not the whole slow group (alarms, jobs, steps, I/O), so
that frequent writes on a slow line do not fill it with reads of values they cannot change; any
other change, or one refused or of unknown outcome, everything."""

from __future__ import annotations

import asyncio
from collections import Counter

import pytest

from robostar.commands.control import SetSpeed
from robostar.commands.motion import Move
from robostar.commands.variables import WriteGlobalInt
from robostar.errors import ControllerError
from robostar.serve import LineConfig, Who
from robostar.serve.line import Line
from robostar.serve.model_keys import changed_by
from robostar.sim import SimConfig, VirtualController
from robostar.types import CoordSystem, MotionType

from .line_fakes import FaultySim, first_poll, poll_reads, wait_for

ANN = Who("ann", "api")
SLOW = ("AB", "ED", "EF", "GA", "GB")
"""The slow group's reads a speed change cannot change (CA, the speed, it can)."""


def _line(sim: FaultySim) -> Line:
    # status and positions every 5 s, the slow group every 60 s: within a test, only a state
    # change makes the poller read anything
    config = LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=60.0)
    return Line(config, client_factory=sim.client)


def test_a_speed_change_rereads_the_speed_only() -> None:
    async def main() -> Counter[str]:
        line = _line(FaultySim())
        await line.start()
        try:
            await first_poll(line)
            read = poll_reads(line)
            await line.execute(SetSpeed(1, 40), who=ANN, implicit_lease=True)
            assert await wait_for(lambda: read["CA"] >= 1, 5.0)
            await line.execute(WriteGlobalInt(3, 7), who=ANN, implicit_lease=True)
            await asyncio.sleep(0.3)  # room for any read the poller would wrongly make
            return read
        finally:
            await line.stop()

    read = asyncio.run(main())
    assert read["CA"] == 1
    assert [code for code in SLOW if read[code]] == []


def test_a_refused_change_rereads_everything() -> None:
    sim = FaultySim()
    sim.controller = VirtualController(SimConfig(speedup=10.0))

    async def main() -> Counter[str]:
        line = _line(sim)
        await line.start()
        try:
            await first_poll(line)
            read = poll_reads(line)
            past_the_limits = Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((150.0, 0, 0, 0),))
            with pytest.raises(ControllerError):
                await line.execute(past_the_limits, who=ANN, implicit_lease=True)
            assert await wait_for(lambda: all(read[code] for code in ("AB", "CA", "GA")), 5.0)
            return read
        finally:
            await line.stop()

    read = asyncio.run(main())
    assert read["AA"] >= 1 and read["AC"] >= 1


def test_what_each_state_change_may_change() -> None:
    assert changed_by(SetSpeed(2, 40)) == {"ch2/speed"}
    assert changed_by(WriteGlobalInt(3, 7)) == frozenset()
    assert changed_by(Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((1.0, 0, 0, 0),))) is None
