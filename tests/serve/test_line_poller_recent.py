"""The poller does not read again what a consumer's read refreshed moments ago (within half a
poll interval, after the last state change): hosts polling AA keep the status fresh for the push
faces, and the wire's time goes to what nobody else reads."""

from __future__ import annotations

import asyncio
import time
from typing import Any

from robostar.commands.base import Command
from robostar.commands.control import SetSpeed
from robostar.commands.status import ReadStatus
from robostar.serve import Who

from .conftest import sim_server
from .line_fakes import first_poll

ANN = Who("ann", "n1")


def test_a_status_hosts_keep_fresh_is_not_polled_again() -> None:
    async def main() -> tuple[int, int, int]:
        async with sim_server(poll_interval=0.4) as server:
            line = server.lines["cell1"]
            await first_poll(line)
            by_poller = [0]
            by_host = [0]

            def count(command: Command[Any], outcome: Any, who: Who | None) -> None:
                if isinstance(command, ReadStatus):
                    (by_host if who == ANN else by_poller)[0] += 1

            line.on_exchange(count)
            cycles = line.health.last_poll
            end = time.monotonic() + 2.0
            while time.monotonic() < end:
                await line.read(ReadStatus(), who=ANN)
                await asyncio.sleep(0.05)
            polled_meanwhile = by_poller[0]
            assert line.health.last_poll != cycles  # the poller did run its cycles
            # a state change: what was read before it is not "recent" any more
            await line.execute(SetSpeed(1, 40), who=ANN, implicit_lease=True)
            await line.wait_polled()
            return polled_meanwhile, by_poller[0], by_host[0]

    meanwhile, after_write, by_host = asyncio.run(main())
    assert by_host > 10
    assert meanwhile == 0
    assert after_write >= 1
