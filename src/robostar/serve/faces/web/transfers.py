"""The program store hears of every file the line moves, whichever face asked for it.

The dashboard keeps its own transfers as versions with what it knows of them (a backup, a
restore, a taught point); an N1 host program's upload or a JSON API download reaches the
controller through the same line but not through the dashboard. The line tells each completed
exchange to its observers (:meth:`Line.on_exchange`): this observer keeps FB uploads and FA
downloads (angle data, as the store keeps PNT files) that other faces made, so the files page's
history holds every change made through the server, and the check for edits at the pendant
flags only what did not come through it.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from robostar.commands.files import DownloadFile, UploadFile
from robostar.serve.lease import Who
from robostar.serve.line import Line
from robostar.serve.programs import ProgramStore, program_text, text_of_lines
from robostar.types import CoordSystem, JobFile, PointFile

__all__ = ["observe_transfers"]

log = logging.getLogger(__name__)

SHARED = Who("several readers", "line")
"""Who a download shared by several requesters is kept for (the line tells no single one)."""


def observe_transfers(line: Line, store: ProgramStore) -> Callable[[], None]:
    """Keep the files ``line`` uploads and downloads for faces other than the dashboard's;
    returns the function that stops it."""

    def observe(command: Any, outcome: Any, who: Who | None) -> None:
        if who is not None and who.face == "web":
            return  # the dashboard keeps its own, with how it came (backup, restore, teach)
        if isinstance(outcome, BaseException):
            return  # not carried out, or not known to be: nothing new on the controller
        try:
            if isinstance(command, UploadFile):
                text = text_of_lines(command.lines)
                store.record(
                    line.name, command.channel, command.file, text, who or SHARED, "upload"
                )
            elif (
                isinstance(command, DownloadFile)
                and command.coords is CoordSystem.ANGLE
                and isinstance(outcome, JobFile | PointFile)
            ):
                text = program_text(outcome)
                store.record(
                    line.name, command.channel, command.file, text, who or SHARED, "download"
                )
        except OSError as exc:  # a full disk: the transfer happened either way
            log.error(
                "programs: %s of %s on %s not kept: %s", command.CODE, command.file, line.name, exc
            )

    return line.on_exchange(observe)
