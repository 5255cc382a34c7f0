"""The status as a witness: values that cannot change while a channel rests are confirmed by
each status read, instead of read again.

A channel *rests* while its status (AA) says servo on, in position and not running: the servo
holds the arm where it is (with the servo off a SCARA's arm can be pushed by hand, so that is
not rest). Its positions (XY and angles) read while it rested stay true as long as every
status read since says it still rests, no state change that may move it went out, and the line
did not drop. Each such status read confirms them: restamps them with its own time, as a read
giving the same value would (nothing is published: the value did not change). The alarm
history likewise, while no status since its read showed an alarm on any channel.

Why: an AC is 56 ms on a 9600-baud line (almost four AA times), the alarm history 88 ms, and an
exchange cannot be interrupted: every host read arriving during one waits for its end. A robot
at rest, the common case for a cell waiting on it, then costs the hosts nothing.

A status read within :data:`SETTLE` seconds of a state change that may move a robot starts no
rest: a controller may answer a motion command (an inching step through the web page, say)
before the motion shows in its status, and a position read then, confirmed after a short move
that ended between two status reads, would be the one before the move.

The limit, and why values are still read every ``rest_interval``: a motion that begins and ends
between two status reads (the poll interval, 0.2 s by default; far less while hosts poll AA)
shows in no status read. Such a motion, made at the pendant, is seen at the next real read, at
the latest ``rest_interval`` after the last one.

Times are ``time.time()`` stamps of the start of each exchange; the line's exchanges are one
after another, so they order the reads exactly.
"""

from __future__ import annotations

import time
from collections.abc import Mapping

from robostar.serve.model import ControllerModel
from robostar.types import ChannelStatus

__all__ = ["SETTLE", "StatusWitness", "rests"]

SETTLE = 0.5
"""Seconds after a state change that may move a robot during which no status read starts a
rest (the motion may not show in the status yet)."""

HISTORY_KEY = "alarm_history"


def rests(status: ChannelStatus) -> bool:
    """The channel is held where it is: servo on, in position, not running."""
    return status.servo_on and status.in_position and not status.running


def position_keys(channel: int) -> tuple[str, str]:
    return f"ch{channel}/position", f"ch{channel}/angles"


class StatusWitness:
    """Confirms a line's rest-bound values by its status reads (see the module docstring)."""

    def __init__(self, model: ControllerModel, rest_interval: float) -> None:
        self.model = model
        self.rest_interval = rest_interval
        """Seconds after a value's last real read beyond which no status confirms it."""
        self._resting_since: dict[int, float] = {}
        """By channel: the first status read of its current rest (absent: not resting, or
        not known to be since the last state change or line drop)."""
        self._quiet_since: float | None = None
        """The first status read of the current run without an alarm on any channel."""
        self._read_at: dict[str, float] = {}
        """By model key: its last real read."""
        self._unsettled_at = 0.0
        """The last :meth:`unsettle`: a status read begun before it witnesses nothing."""
        self.confirmed = 0
        """Values confirmed since start (the bench's figure)."""

    def read(self, key: str, at: float) -> None:
        """``key`` was read from the controller, in an exchange begun at ``at``."""
        self._read_at[key] = at

    def status(self, statuses: Mapping[int, ChannelStatus], at: float) -> None:
        """A status read (of the channels the controller has) begun at ``at``: follow each
        channel's rest, then confirm what it vouches for."""
        if at < self._unsettled_at:
            return  # it began before the state change (and landed after): no witness of now
        if at < self._unsettled_at + SETTLE:
            # the change's motion (or alarm) may not show yet: this status vouches for nothing
            self._resting_since.clear()
            self._quiet_since = None
            return
        for channel, status in statuses.items():
            if rests(status):
                self._resting_since.setdefault(channel, at)
            else:
                self._resting_since.pop(channel, None)
        if any(status.alarm for status in statuses.values()):
            self._quiet_since = None
        elif self._quiet_since is None:
            self._quiet_since = at
        for channel, since in self._resting_since.items():
            for key in position_keys(channel):
                self._confirm(key, since, at)
        if self._quiet_since is not None:
            self._confirm(HISTORY_KEY, self._quiet_since, at)

    def unsettle(self) -> None:
        """A state change that may move a robot or raise an alarm went out, or the line dropped
        or opened: nothing read before now is confirmed again until read again."""
        self._unsettled_at = time.time()
        self._resting_since.clear()
        self._quiet_since = None

    def _confirm(self, key: str, since: float, at: float) -> None:
        read_at = self._read_at.get(key)
        # read during this rest (not before it: it may have been read mid-motion), and not so
        # long ago that a motion hidden between two status reads may have gone unseen for long
        if read_at is None or read_at <= since or at - read_at >= self.rest_interval:
            return
        if self.model.confirm(key, at):
            self.confirmed += 1
