"""Line.on_exchange: other parts of the server (the web face's program store, a recorder) see
every exchange the line completes, with its outcome and who asked, without reaching into the
line; an observer that fails does not stop the line, and one removed hears no more."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from robostar.commands.base import Command
from robostar.commands.control import ReadSpeed
from robostar.commands.files import DownloadFile, UploadFile
from robostar.commands.motion import Move
from robostar.errors import ControllerError
from robostar.serve import Who
from robostar.types import CoordSystem, MotionType

from .conftest import sim_server

ERIN = Who("erin", "web")
JOB = ["MAIN", "MOVJ P0001 V=50", "EOP"]


def test_observers_see_uploads_downloads_refusals_and_who_asked() -> None:
    seen: list[tuple[Command[Any], Any, Who | None]] = []

    def failing(command: Command[Any], outcome: Any, who: Who | None) -> None:
        raise RuntimeError("a broken observer")

    async def main() -> None:
        async with sim_server(poll_interval=5.0) as server:
            line = server.lines["cell1"]
            await line.wait_polled()
            line.on_exchange(failing)
            remove = line.on_exchange(lambda *exchange: seen.append(exchange))
            upload = UploadFile(1, "WELD.JOB", 1, JOB)
            await line.execute(upload, who=ERIN, implicit_lease=True)
            download = DownloadFile(1, "WELD.JOB", CoordSystem.ANGLE)
            content = await line.read(download, who=ERIN)
            unhomed = Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((10.0, 20.0, 30.0, 0.0),))
            with pytest.raises(ControllerError):
                await line.execute(unhomed, who=ERIN)  # refused: the robot is not homed
            remove()
            heard = len(seen)
            await line.read(ReadSpeed(1))
            assert len(seen) == heard
            erins = [exchange for exchange in seen if exchange[2] == ERIN]
            assert [exchange[0] for exchange in erins] == [upload, download, unhomed]
            assert erins[1][1] == content and isinstance(erins[2][1], ControllerError)
            assert any(who is None for _, _, who in seen)  # the poller's reads, after the upload

    asyncio.run(main())
