"""A line's control as faces show and change it: who holds it, through which face, until when
(wall clock and monotonic), whether it is one-shot; take (audited, refused when another holds
it, kept past its holder's one-shot commands) and release (its holder only, audited). The calls
the web face makes on the lease itself (holder, acquire with seconds, release) keep working."""

from __future__ import annotations

import asyncio
import json
import time
from pathlib import Path

import pytest

from robostar.commands.control import SetSpeed
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.lease import LeaseHeldError, Who

OLGA = Who("olga", "web")
MES = Who("mes-1", "mqtt")


def test_control_is_shown_taken_and_released(tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        config = ServeConfig(lines=(LineConfig("cell1", "sim://"),), audit_path=str(audit))
        async with LineServer(config) as server:
            line = server.lines["cell1"]
            free = line.control()
            assert free.free and free.holder is None and free.as_dict()["free"] is True
            before = time.time()
            info = line.take_control(OLGA, 300)
            state = line.control()
            assert (state.holder, state.face, state.once) == ("olga", "web", False)
            assert state.until == info.expires_at and state.until >= before + 299
            assert state.left is not None and 299 <= state.left <= 300
            assert state.until_monotonic is not None
            assert abs(state.until_monotonic - time.monotonic() - state.left) < 5
            await line.execute(SetSpeed(1, 30), who=OLGA, implicit_lease=True)
            assert line.lease.held_by(OLGA)  # a take is kept past one-shot commands
            with pytest.raises(LeaseHeldError, match=r"olga \(web\) until \d\d:\d\d:\d\d UTC"):
                line.take_control(MES)
            assert not line.release_control(MES)  # only the holder releases
            assert line.release_control(OLGA)
            assert line.control().free
            # what the web face calls on the lease itself
            line.lease.acquire(OLGA, 300)
            holder = line.lease.holder
            assert holder is not None and holder.who == OLGA and holder.expires_at > time.time()
            assert line.lease.release(OLGA)

    asyncio.run(main())
    entries = [json.loads(raw) for raw in audit.read_text().splitlines()]
    mine = [(e["who"], e["what"], e["outcome"].split(":")[0]) for e in entries]
    assert ("olga", "lease take", "ok") in mine
    assert ("mes-1", "lease take", "refused") in mine
    assert ("mes-1", "lease release", "not held") in mine
    assert ("olga", "lease release", "ok") in mine
