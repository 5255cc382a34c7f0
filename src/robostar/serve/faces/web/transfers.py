"""The program store hears of every file written through the server, whichever face wrote it.

The dashboard keeps its own transfers as versions with what it knows of them (a backup, a
restore, a taught point); an N1 host program's upload or a JSON API upload reaches the
controller through the same line but not through the dashboard. The line tells each completed
exchange to its observers (:meth:`Line.on_exchange`): this observer keeps the FB uploads other
faces made, so the files page's history holds every change made through the server, and the
check for edits at the pendant flags only what did not come through it. Downloads by other faces
(and the check's own reads) are not kept: a download reads what the controller holds, edits made
at the pendant included, and keeping it as the last version would hide them from the check.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from robostar.commands.files import UploadFile
from robostar.serve.lease import Who
from robostar.serve.line import Line
from robostar.serve.programs import ProgramStore, text_of_lines

__all__ = ["observe_transfers"]

log = logging.getLogger(__name__)

UNKNOWN = Who("unknown", "line")
"""Who an upload is kept for when the line names no requester."""


def observe_transfers(line: Line, store: ProgramStore) -> Callable[[], None]:
    """Keep the files ``line`` uploads for faces other than the dashboard's;
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
                    line.name, command.channel, command.file, text, who or UNKNOWN, "upload"
                )
        except OSError as exc:  # a full disk: the transfer happened either way
            log.error(
                "programs: %s of %s on %s not kept: %s", command.CODE, command.file, line.name, exc
            )

    return line.on_exchange(observe)
