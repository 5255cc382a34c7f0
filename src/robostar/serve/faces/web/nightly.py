"""The nightly program check (``program_check_at = "02:30"`` in ``[web]``): once a day, at that
local time, every line's files are compared with their last kept versions (serve/programs.py's
check), as the files page's button does, and the result is in the audit log ("nightly program
check: ..."), so an edit made at the pendant is on record by the next morning."""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import logging

from robostar.errors import RobostarError, UsageError
from robostar.serve.faces.web.views import channels
from robostar.serve.lease import Who
from robostar.serve.line_server import LineServer
from robostar.serve.programs import ProgramStore, check

__all__ = ["NIGHTLY", "parse_time", "run_nightly", "seconds_until"]

log = logging.getLogger(__name__)
NIGHTLY = Who("nightly program check", "web")


def parse_time(text: object) -> datetime.time:
    """``"HH:MM"`` (24 h, local time)."""
    try:
        hours, minutes = str(text).strip().split(":")
        return datetime.time(int(hours), int(minutes))
    except ValueError:
        raise UsageError(f"web: program_check_at {text!r} is not HH:MM (e.g. 02:30)") from None


def seconds_until(at: datetime.time, now: datetime.datetime) -> float:
    """Seconds from ``now`` to the next ``at`` (tomorrow's when today's has passed)."""
    target = now.replace(hour=at.hour, minute=at.minute, second=0, microsecond=0)
    if target <= now:
        target += datetime.timedelta(days=1)
    return (target - now).total_seconds()


async def check_all(server: LineServer, store: ProgramStore) -> None:
    for line in server.lines.values():
        try:
            drift = await check(store, line, channels(line), NIGHTLY)
        except RobostarError as exc:
            line.record("nightly program check", NIGHTLY, f"error: {exc}")
            continue
        flagged = [f"{d.name} (channel {d.channel}) {d.state}" for d in drift if d.state != "same"]
        outcome = "ok" if not flagged else "flagged: " + ", ".join(flagged)
        line.record(f"nightly program check: {len(drift)} files", NIGHTLY, outcome[:1000])


async def run_nightly(server: LineServer, store: ProgramStore, at: datetime.time) -> None:
    """Check every day at ``at`` until cancelled."""
    while True:
        await asyncio.sleep(seconds_until(at, datetime.datetime.now()))
        with contextlib.suppress(RobostarError):
            await check_all(server, store)
        log.info("nightly program check done")
