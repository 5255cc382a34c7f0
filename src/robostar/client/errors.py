"""Errors of the client's own logic (waiting for the robot, jogging), under RobostarError.

They extend the tree of :mod:`robostar.errors`::

    RobostarError
    └── WaitError                          waiting for the robot ended without success
        ├── WaitTimeoutError (TimeoutError)    the condition did not come in time
        └── AlarmRaisedError               the channel raised an alarm while it was awaited
    RobostarError
    └── JogInterruptedError                a jog's keepalive failed; the robot has stopped
"""

from __future__ import annotations

from robostar.errors import RobostarError
from robostar.types import Alarm, ChannelStatus

__all__ = ["AlarmRaisedError", "JogInterruptedError", "WaitError", "WaitTimeoutError"]


class WaitError(RobostarError):
    """Waiting for a channel ended without the awaited condition; ``status`` is the last read."""

    def __init__(self, message: str, channel: int, status: ChannelStatus | None) -> None:
        self.channel = channel
        self.status = status
        super().__init__(message)


class WaitTimeoutError(WaitError, TimeoutError):
    """The awaited condition did not come within the timeout."""


class AlarmRaisedError(WaitError):
    """The channel raised an alarm while it was awaited; ``alarms`` are the current alarms."""

    def __init__(
        self, message: str, channel: int, status: ChannelStatus, alarms: tuple[Alarm, ...]
    ) -> None:
        self.alarms = alarms
        super().__init__(message, channel, status)


class JogInterruptedError(RobostarError):
    """A jog keepalive (BF) failed, so the controller stopped the jog; ``__cause__`` says why."""
