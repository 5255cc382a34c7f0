"""The push faces' view judged against the journal (reliability/history_model.py): every good
sample of the line's model is a position the controller held at its stamped time. A status
witness that vouched for a moving arm would be caught, which is what makes the history runs'
"0 violations" in the model's samples evidence."""

from __future__ import annotations

import asyncio

import pytest
from reliability.history_judge import judge
from reliability.history_model import ModelWatcher
from tests.serve.line_fakes import FaultySim, first_poll, wait_for

from robostar.client.aio import AsyncClient
from robostar.commands.job import Servo
from robostar.commands.motion import Home
from robostar.serve import LineConfig, Who
from robostar.serve.line import Line
from robostar.serve.status_witness import rests
from robostar.sim import SimConfig, VirtualController
from robostar.sim.journal import Journal
from robostar.transport.inproc import AsyncPeerTransport

ANN = Who("ann", "api")


def _pendant_moves_the_arm() -> tuple[int, int]:
    """A line at rest; the pendant (a session of its own) moves channel 1; the model's samples
    of it judged: (samples, violations)."""
    journal = Journal(keep=True)
    sim = FaultySim()
    sim.controller = VirtualController(SimConfig(), journal=journal)

    async def main() -> ModelWatcher:
        line = Line(
            LineConfig("cell1", "sim://", poll_interval=0.05, slow_interval=60.0),
            client_factory=sim.client,
        )
        await line.start()
        # in process an exchange takes about a millisecond
        watcher = ModelWatcher(lambda: line.model, (1,), exchange_bound=0.2)
        try:
            await first_poll(line)
            await line.execute(Servo(1, True), who=ANN, implicit_lease=True)
            await line.execute(Home(1), who=ANN, implicit_lease=True)

            def resting() -> bool:
                sample = line.model.get("ch1/status")
                return sample is not None and sample.value.origin and rests(sample.value)

            assert await wait_for(resting, 10.0)
            await asyncio.sleep(0.3)
            watcher.start()
            async with AsyncClient(AsyncPeerTransport(sim.controller.open_session("p"))) as pendant:
                await pendant.move_by(1, (60.0, 0.0, 0.0, 0.0), wait=True)
            await asyncio.sleep(0.3)
            return watcher
        finally:
            watcher.stop()
            await line.stop()

    watcher = asyncio.run(main())
    verdict = judge(journal.entries or [], watcher.ops)
    return len(watcher.ops), len(verdict.violations)


def test_the_models_samples_are_positions_the_controller_held() -> None:
    samples, violations = _pendant_moves_the_arm()
    assert samples >= 5  # read along the path (a read every poll cycle while it moves)
    assert violations == 0


def test_a_witness_that_vouches_for_a_moving_arm_is_caught(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("robostar.serve.status_witness.rests", lambda status: True)
    _, violations = _pendant_moves_the_arm()
    assert violations >= 1
