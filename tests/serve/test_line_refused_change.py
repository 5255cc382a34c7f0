"""A state change the controller refuses may still change it (a move past the soft limits raises
alarm 9003): the model's values are not vouched for after it, and the poller reads again at
once, so push views (MQTT, OPC UA, the web page) see the alarm without waiting for the next
poll."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from robostar.commands.motion import Home, Move
from robostar.commands.status import ReadStatus
from robostar.errors import ControllerError
from robostar.serve import LineConfig, Who
from robostar.serve.audit import AuditLog
from robostar.serve.line import Line
from robostar.sim import SimConfig, VirtualController
from robostar.sim.alarms import AlarmCode
from robostar.types import CoordSystem, MotionType

from .line_fakes import FaultySim, wait_for

ANN = Who("ann", "api")


def test_a_refused_move_refreshes_the_model_at_once(tmp_path: Path) -> None:
    sim = FaultySim()
    sim.controller = VirtualController(SimConfig(speedup=10.0))

    async def main() -> tuple[bool, bool]:
        audit = AuditLog(tmp_path / "audit.jsonl")
        audit.open()
        config = LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0)
        line = Line(config, client_factory=sim.client, audit=audit)
        await line.start()
        try:
            await line.execute(Home(1), who=ANN, implicit_lease=True)
            while not (await line.read(ReadStatus(), max_age=0))[0].origin:
                await asyncio.sleep(0.02)
            await line.wait_polled()
            before = line.model.get("ch1/status")
            assert before is not None and not before.value.alarm
            past_the_limits = Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((150.0, 0, 0, 0),))
            with pytest.raises(ControllerError):
                await line.execute(past_the_limits, who=ANN)

            def status_alarm() -> bool:
                sample = line.model.get("ch1/status")
                return sample is not None and sample.value.alarm

            def alarm_listed() -> bool:
                sample = line.model.get("alarms")
                return sample is not None and AlarmCode.SOFT_LIMIT in [a.code for a in sample.value]

            # well before the next poll (5 s) would have seen it
            return await wait_for(status_alarm, 2.0), await wait_for(alarm_listed, 2.0)
        finally:
            await line.stop()

    assert asyncio.run(main()) == (True, True)
