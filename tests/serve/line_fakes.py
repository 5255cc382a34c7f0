"""A line in front of the in-process simulator, with faults on demand (not a conftest: the tests
that need it import it).

The faults are the ones a shared line meets: a controller that refuses a read for the moment
(0x32) or for good (0x33), an exchange that takes long (a slow read, a transfer) so that other
requests wait in the queue, an answer lost after the controller carried the command out, and a
port that drops.
"""

from __future__ import annotations

import asyncio
from collections import Counter
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from robostar.client.aio import AsyncClient
from robostar.client.exchange import Progress
from robostar.commands.base import Command
from robostar.commands.control import ReadSpeed
from robostar.serve import LineConfig, LineServer, ServeConfig, Who
from robostar.serve.line import Line
from robostar.sim import SimConfig, VirtualController
from robostar.transport.inproc import AsyncPeerTransport

Fault = Callable[[Command[Any]], BaseException | None]
"""Given the command about to be run, the error to raise instead (nothing is sent), or None."""


class FaultySim:
    """The simulator behind a line's client, and the faults its client plays."""

    def __init__(self) -> None:
        self.controller = VirtualController(SimConfig())
        self.before: list[Fault] = []
        """Checked in order before a command goes out; the first error returned is raised."""
        self.after: list[Fault] = []
        """Checked after the controller carried a command out: an error raised instead of the
        answer (an answer lost on the line)."""
        self.write_delay = 0.0
        """Seconds every write to the line waits before its bytes go (a slow line)."""
        self.sent: list[Command[Any]] = []
        """Every command a client ran on the line (its request went out), in order."""

    def refuse_once(
        self,
        kind: type[Command[Any]],
        error: BaseException,
        where: Callable[[Any], bool] = lambda command: True,
    ) -> None:
        """The next ``kind`` command (for which ``where`` holds) is answered with ``error``
        (nothing reaches the robot)."""
        armed = [True]

        def fault(command: Command[Any]) -> BaseException | None:
            if isinstance(command, kind) and armed[0] and where(command):
                armed[0] = False
                return error
            return None

        self.before.append(fault)

    def client(self, config: LineConfig) -> AsyncClient:
        """A ``client_factory`` for :class:`~robostar.serve.line.Line` and ``LineServer``."""
        sim = self

        class SlowTransport(AsyncPeerTransport):
            async def write(self, data: bytes) -> None:
                if sim.write_delay:
                    await asyncio.sleep(sim.write_delay)
                await super().write(data)

        class Client(AsyncClient):
            async def execute(self, command: Command[Any], progress: Progress | None = None) -> Any:
                for fault in sim.before:
                    error = fault(command)
                    if error is not None:
                        raise error
                sim.sent.append(command)
                result = await super().execute(command, progress)
                for fault in sim.after:
                    error = fault(command)
                    if error is not None:
                        raise error
                return result

        return Client(SlowTransport(self.controller, url="sim://"), timeout=3.0)


async def wait_for(predicate: Callable[[], bool], timeout: float = 3.0) -> bool:
    """Poll ``predicate`` every 10 ms until it holds (True) or ``timeout`` passes (False)."""
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while not predicate():
        if loop.time() >= end:
            return False
        await asyncio.sleep(0.01)
    return True


async def hold_the_line(line: Line, sim: FaultySim) -> asyncio.Task[int]:
    """A slow read on the wire, so that what is queued next waits (await the task after)."""
    sim.write_delay = 0.3
    read = ReadSpeed(2)
    busy = asyncio.create_task(line.read(read, max_age=0))
    assert await wait_for(lambda: line._current is not None and line._current.command is read)
    return busy


@asynccontextmanager
async def n1_server(sim: FaultySim, audit: Path) -> AsyncIterator[tuple[Line, str, int]]:
    """A line server of one line (cell1) in front of ``sim``, its N1 face on a free loopback
    port, auditing to ``audit``: the line, and the face's host and port."""
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=5.0, slow_interval=5.0),),
        faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
        audit_path=str(audit),
    )
    async with LineServer(config, client_factory=sim.client) as server:
        line = server.lines["cell1"]
        await line.wait_polled()
        host, port = server.faces["n1"].addresses["cell1"]  # type: ignore[attr-defined]
        yield line, host, port


def poll_reads(line: Line) -> Counter[str]:
    """The poller's exchanges on ``line`` from now on, counted by code (filled as they end)."""
    read: Counter[str] = Counter()

    def count(command: Command[Any], outcome: Any, who: Who | None) -> None:
        if who is None:
            read[command.CODE] += 1

    line.on_exchange(count)
    return read


async def first_poll(line: Line, timeout: float = 10.0) -> None:
    """Wait until the line's first poll cycle has ended (the model holds every key). Unlike
    ``wait_polled`` it never waits for a next cycle, which a slow poller starts seconds later."""
    assert await wait_for(lambda: line.health.last_poll is not None, timeout)
