"""Who holds a line's control, as a value both encodings publish (``<prefix>/<line>/control``,
retained; Sparkplug metrics ``control/holder`` ...).

The lease lives in the line server's memory and says nothing when it changes, so each line's
pump looks at it every :data:`CONTROL_EVERY` seconds and offers it to its reporter, which sends
it only when it differs from what was last sent (and again after every reconnect). A one-shot
lease, held for one command of a few milliseconds, may come and go between two looks: that is
its point (it never keeps anyone out); a lease taken for a sequence is seen.
"""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

from robostar.serve.faces.mqtt.reporter import Reporter
from robostar.serve.model import Sample

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["CONTROL_EVERY", "CONTROL_KEY", "ControlView", "control_sample", "watch_control"]

CONTROL_KEY = "control"
CONTROL_EVERY = 0.25
"""How often a pump looks at its line's lease (seconds)."""


@dataclass(frozen=True)
class ControlView:
    """A line's lease as published. Every field keeps its type whether the lease is free or
    held (a Sparkplug metric's datatype must not change without a rebirth): ``holder`` and
    ``face`` are ``""`` and ``until`` (Unix seconds) ``0.0`` when it is free; ``once``: a
    one-shot lease (one command's, given back as it ends)."""

    free: bool
    holder: str
    face: str
    until: float
    once: bool


def control_sample(line: Line) -> Sample:
    """The line's lease now, as a model-like sample (taken now, always of good quality: the
    lease is the server's own state, not a reading of the robot)."""
    state = line.control()
    view = ControlView(
        free=state.free,
        holder=state.holder or "",
        face=state.face or "",
        until=round(state.until, 3) if state.until is not None else 0.0,
        once=state.once,
    )
    return Sample(view, time.time())


async def watch_control(line: Line, reporter: Reporter, wake: asyncio.Event) -> None:
    """Offer ``line``'s lease to ``reporter`` for ever, waking the pump when it is to be sent."""
    while True:
        reporter.offer(CONTROL_KEY, control_sample(line))
        if reporter.holds(CONTROL_KEY):
            wake.set()
        await asyncio.sleep(CONTROL_EVERY)
