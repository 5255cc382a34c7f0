"""The line's queue order and its jobs: what the worker takes, in which order.

Stops (CF, CD, CI, BG) go first, then a jog keepalive (BF), then the consumers' requests,
writes and reads alike, first come first served, and last the poller's reads: they use the
time the consumers leave. A poll read that would let the model go stale waiting takes its
place among the consumers' requests instead (at the back, as if it had just come), so that no
number of readers can starve the poller, and none waits for more than one of its reads.

Why writes do not pass reads: a host's read would then wait for the exchange on the wire, any
number of writes that came after it, and its own flight. First come first served, it waits for
the exchange on the wire and the flights queued before it (one per distinct read: identical
reads share a flight), and a write waits likewise; what must not wait goes as a stop.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from robostar.commands.base import Command
from robostar.commands.control import EmergencyStop, StopHoming, StopJob
from robostar.commands.files import DownloadFile, ReadAlarmHistory, UploadFile
from robostar.commands.motion import JogStop
from robostar.serve.lease import Who

__all__ = [
    "PRI_KEEPALIVE",
    "PRI_LATE_POLL",
    "PRI_POLL",
    "PRI_REQUEST",
    "PRI_STOP",
    "STOPS",
    "TRANSFERS",
    "Job",
]

STOPS = (EmergencyStop, StopJob, StopHoming, JogStop)
"""CF, CD, CI, BG: anyone may send them (no lease), and they jump every queue."""
TRANSFERS = (UploadFile, DownloadFile, ReadAlarmHistory)
"""Long multi-packet exchanges a stop cancels rather than waits for."""

PRI_STOP, PRI_KEEPALIVE, PRI_REQUEST, PRI_POLL = range(4)
"""Queue order, lowest first (and within one, the order of arrival)."""
PRI_LATE_POLL = PRI_REQUEST
"""A poll read of a model gone unrefreshed too long: in the consumers' queue, at its back."""


@dataclass(order=True)
class Job:
    """One exchange waiting for (or on) the line; its future gets the answer."""

    priority: int
    seq: int
    command: Command[Any] = field(compare=False)
    future: asyncio.Future[Any] = field(compare=False)
    who: Who | None = field(compare=False, default=None)
    """Whose request it is (None: shared by several readers, or the poller's)."""
    started: bool = field(compare=False, default=False)
    """The worker took it: its request may be on the wire."""
    shared_by: Callable[[], Who | None] | None = field(compare=False, default=None)
    """For a read flight's job: who its readers are, when one requester (else None)."""
    began: float = field(compare=False, default=math.nan)
    """``time.time()`` as its exchange began (NaN until then): its answer is a sample of the
    controller at some instant from then to its end, so this is the answer's oldest time."""
