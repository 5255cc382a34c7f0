"""A jog start (BE) whose answer was lost may have set the axis moving, and nobody keeps it
alive: the line server stops it at once (BG, audited), as the client's own Jog does."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from robostar.commands.base import Command
from robostar.commands.motion import JogStart, JogStop
from robostar.errors import OutcomeUnknownError
from robostar.serve import LineConfig, Who
from robostar.serve.audit import AuditLog
from robostar.serve.line import Line
from robostar.types import JogDirection, MotionType

from .line_fakes import FaultySim, wait_for

ANN = Who("ann", "api")


def test_a_jog_start_of_unknown_outcome_is_stopped_at_once(tmp_path: Path) -> None:
    sim = FaultySim()
    audit = tmp_path / "audit.jsonl"

    def lost(command: Command[Any]) -> BaseException | None:
        if isinstance(command, JogStart):
            return OutcomeUnknownError("BE", "the answer was lost")
        return None

    async def main() -> None:
        log = AuditLog(audit)
        log.open()
        line = Line(
            LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0),
            audit=log,
            client_factory=sim.client,
        )
        await line.start()
        try:
            await line.wait_polled()
            sim.after.append(lost)  # BE carried out, its answer lost
            start = JogStart(1, 1, JogDirection.PLUS, MotionType.JOINT)
            with pytest.raises(OutcomeUnknownError):
                await line.execute(start, who=ANN, implicit_lease=True)
            assert await wait_for(lambda: any(isinstance(c, JogStop) for c in sim.sent))
            await asyncio.sleep(0.05)
        finally:
            await line.stop()
            log.close()

    asyncio.run(main())
    entries = [json.loads(text) for text in audit.read_text().splitlines()]
    assert any(
        e["what"].startswith("JogStop") and "outcome was unknown" in e["outcome"] for e in entries
    ), entries
