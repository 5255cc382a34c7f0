"""The line's queue order and its jobs: what the worker takes, in which order.

Stops (CF, CD, CI, BG) go first, then a jog keepalive (BF), then writes, then consumers' reads
and last the poller's reads (unless the model would go stale waiting: then before the
consumers' reads, so that no number of readers can starve it).
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from robostar.commands.base import Command
from robostar.serve.lease import Who

__all__ = [
    "PRI_KEEPALIVE",
    "PRI_LATE_POLL",
    "PRI_POLL",
    "PRI_READ",
    "PRI_STOP",
    "PRI_WRITE",
    "Job",
]

PRI_STOP, PRI_KEEPALIVE, PRI_WRITE, PRI_LATE_POLL, PRI_READ, PRI_POLL = range(6)
"""Queue order, lowest first. The poller's reads come last, unless the model has gone
unrefreshed too long: then they go before the consumers' reads (PRI_LATE_POLL)."""


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
