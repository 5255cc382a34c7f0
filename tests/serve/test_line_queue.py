"""The queue: a stop pre-empts an upload; consumers never interleave; line loss and reconnect."""

from __future__ import annotations

import asyncio
import re

import pytest

from robostar.client.aio import AsyncClient
from robostar.commands.control import EmergencyStop, ReadSpeed, SetSpeed
from robostar.commands.files import UploadFile
from robostar.commands.status import ReadStatus
from robostar.errors import OutcomeUnknownError
from robostar.serve import AbortedByStopError, LineConfig, LineDownError, Quality, Who
from robostar.serve.line import Line
from robostar.sim import SimConfig, VirtualController
from robostar.transport.inproc import AsyncPeerTransport

from .conftest import sim_server

HOST = Who("host", "n1")
OPERATOR = Who("operator", "web")


def _job_lines(count: int) -> list[str]:
    body = [f"MOVJ P{(i % 100) + 1:04d} V=50" for i in range(count - 2)]
    return ["MAIN", *body, "EOP"]


def test_a_stop_preempts_a_2000_line_upload() -> None:
    async def main() -> None:
        async with sim_server(poll_interval=0.5) as server:
            line = server.lines["cell1"]
            upload = asyncio.create_task(
                line.execute(
                    UploadFile(1, "BIG.JOB", 7, _job_lines(2000)), who=HOST, implicit_lease=True
                )
            )
            while line._current is None or not isinstance(line._current.command, UploadFile):
                await asyncio.sleep(0.001)
            await asyncio.sleep(0.02)
            await line.execute(EmergencyStop(), who=OPERATOR)  # no lease needed for a stop
            assert not upload.done() or upload.exception() is not None
            with pytest.raises(AbortedByStopError, match="aborted by stop CF") as caught:
                await upload
            accepted = re.search(r"after (\d+) of 2000 lines accepted", str(caught.value))
            assert accepted is not None, caught.value
            assert 0 <= int(accepted.group(1)) < 2000
            status = await line.read(ReadStatus(), max_age=0)
            assert len(status) == 3

    asyncio.run(main())


def test_two_consumers_never_interleave_on_the_line() -> None:
    """A tight poller and a host program writing and reading back, at once: every answer matches."""

    async def main() -> None:
        async with sim_server(poll_interval=0.01) as server:
            line = server.lines["cell1"]

            async def poller() -> int:
                n = 0
                for _ in range(60):
                    assert len(await line.read(ReadStatus(), max_age=0)) == 3
                    n += 1
                return n

            async def host() -> None:
                for value in range(10, 40):
                    await line.execute(SetSpeed(1, value), who=HOST, implicit_lease=True)
                    assert await line.read(ReadSpeed(1)) == value

            count, _ = await asyncio.gather(poller(), host())
            assert count == 60
            assert line.health.errors == 0

    asyncio.run(main())


class _Unpluggable:
    """A simulator behind a transport the test can break and mend (a cable pulled and put back)."""

    def __init__(self) -> None:
        self.controller = VirtualController(SimConfig())
        self.broken = False
        self.opened = 0

    def client(self, config: LineConfig) -> AsyncClient:
        outer = self

        class Transport(AsyncPeerTransport):
            async def open(self) -> None:
                if outer.broken:
                    from robostar.errors import PortError

                    raise PortError("cable unplugged")
                outer.opened += 1
                await super().open()

            async def write(self, data: bytes) -> None:
                if outer.broken:
                    from robostar.errors import PortError

                    raise PortError("cable unplugged")
                await super().write(data)

        return AsyncClient(Transport(self.controller, url="sim://"), timeout=0.3)


def test_line_loss_and_reconnect() -> None:
    async def main() -> None:
        plug = _Unpluggable()
        line = Line(LineConfig("cell1", "sim://", poll_interval=0.02), client_factory=plug.client)
        await line.start()
        try:
            assert line.up
            await line.wait_polled()
            plug.broken = True
            while line.up:
                await asyncio.sleep(0.01)
            assert line.model.get("online").value is False  # type: ignore[union-attr]
            status = line.model.get("ch1/status")
            assert status is not None and status.quality is Quality.LINE_DOWN
            with pytest.raises(LineDownError, match="down"):
                await line.read(ReadSpeed(1), max_age=0)
            assert "unplugged" in (line.health.last_error or "")
            plug.broken = False
            async with asyncio.timeout(10):
                while not line.up:
                    await asyncio.sleep(0.01)
            await line.wait_polled()
            assert line.health.reconnects == 1
            assert plug.opened == 2
            assert await line.read(ReadSpeed(1), max_age=0) == 300
            assert line.model.get("ch1/status").quality is Quality.GOOD  # type: ignore[union-attr]
        finally:
            await line.stop()

    asyncio.run(main())


def test_a_line_whose_client_cannot_even_be_made_is_down_not_hung() -> None:
    """Any exception while opening (not only the library's own) leaves the line down and
    retrying; start() returns after the first attempt instead of waiting for ever."""
    made = []

    def factory(config: LineConfig) -> AsyncClient:
        made.append(config)
        if len(made) < 2:
            raise ValueError("Invalid IPv6 URL")
        return _Unpluggable().client(config)

    async def main() -> None:
        line = Line(LineConfig("cell1", "sim://"), client_factory=factory)
        async with asyncio.timeout(10):
            await line.start()
        try:
            assert not line.up
            assert "ValueError: Invalid IPv6 URL" in (line.health.last_error or "")
            async with asyncio.timeout(10):
                while not line.up:  # the worker lived on and tried again
                    await asyncio.sleep(0.01)
        finally:
            await line.stop()

    asyncio.run(main())


def test_a_worker_that_dies_at_start_is_an_error_not_a_hang(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    async def broken_worker(self: Line) -> None:
        raise RuntimeError("a bug")

    monkeypatch.setattr(Line, "_worker", broken_worker)

    async def main() -> None:
        line = Line(LineConfig("cell1", "sim://"))
        with pytest.raises(LineDownError, match="worker stopped at start: RuntimeError"):
            async with asyncio.timeout(10):
                await line.start()
        await line.stop()

    asyncio.run(main())


def test_a_line_that_cannot_open_is_down_and_keeps_trying() -> None:
    async def main() -> None:
        plug = _Unpluggable()
        plug.broken = True
        line = Line(LineConfig("cell1", "sim://"), client_factory=plug.client)
        await line.start()
        try:
            assert not line.up
            with pytest.raises(LineDownError, match="cable unplugged"):
                await line.execute(SetSpeed(1, 5), who=HOST, implicit_lease=True)
            plug.broken = False
            async with asyncio.timeout(10):
                while not line.up:
                    await asyncio.sleep(0.01)
        finally:
            await line.stop()

    asyncio.run(main())


def test_stopping_fails_every_waiter_with_a_clear_error() -> None:
    async def main() -> None:
        server = sim_server(poll_interval=0.5)
        await server.start()
        line = server.lines["cell1"]
        big = UploadFile(1, "BIG.JOB", 7, _job_lines(2000))
        upload = asyncio.create_task(line.execute(big, who=HOST, implicit_lease=True))
        while line._current is None or not isinstance(line._current.command, UploadFile):
            await asyncio.sleep(0.001)
        reads = [asyncio.create_task(line.read(ReadSpeed(1), max_age=0)) for _ in range(5)]
        await asyncio.sleep(0.02)
        async with asyncio.timeout(5):
            await server.stop()
        for task in reads:
            try:
                await task
            except LineDownError as exc:
                assert "stop" in str(exc)
        # the upload was on the wire: its outcome is unknown, never "nothing was sent"
        with pytest.raises(OutcomeUnknownError, match="server stopped during the exchange"):
            await upload

    asyncio.run(main())
