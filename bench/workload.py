"""The requests and answers the benchmarks exchange: a 2000-line job and canned answers."""

from __future__ import annotations

from robostar.types import ArmForm, ChannelStatus, Point, Position, PositionKind

__all__ = ["JOB_NAME", "POINT", "POSITION", "STATUS", "job_lines"]

JOB_NAME = "BENCH.JOB"
STATUS = (
    ChannelStatus(servo_on=True, origin=True, ready=True, in_position=True),
    ChannelStatus(ready=True),
    ChannelStatus(),
)
POSITION = Position(PositionKind.XY, (412.5, -120.25, 35.0, 90.125), ArmForm.RIGHT)
"""AC of a 4-axis SCARA, as the simulator's channel 1 answers it."""
POINT = Point((412.5, -120.25, 35.0, 90.125, 0.0, 0.0), ArmForm.RIGHT, True)
"""GR of a whole global point: 6 axes + USED + ARM, the longest single GR answer."""

_STEPS = (
    "JMOV P{n}",
    "LMOV P{n}",
    "OUT 0,{c},1",
    "DELAY 50",
    "WAIT IN 0,{c},1",
    "OUT 0,{c},0",
)


def job_lines(count: int) -> tuple[str, ...]:
    """A job of ``count`` lines (``MAIN`` ... ``EOP``) the simulator can run."""
    if count < 2:
        raise ValueError(f"count: a job has MAIN and EOP at least, not {count} lines")
    body = tuple(_STEPS[i % len(_STEPS)].format(n=i % 99 + 1, c=i % 16) for i in range(count - 2))
    return ("MAIN", *body, "EOP")
