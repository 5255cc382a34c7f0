"""What a line answers when it cannot carry a request out (each says whether anything was sent)."""

from __future__ import annotations

from robostar.errors import LineError

__all__ = ["AbortedByStopError", "LineBusyError", "LineDownError", "WithdrawnError"]


class LineDownError(LineError):
    """The line is down (or the server is stopping); nothing was sent."""


class LineBusyError(LineError):
    """Too many reads are waiting for this line; nothing was sent. Try again shortly."""


class AbortedByStopError(LineError):
    """A transfer in progress was cancelled so that a stop could go out at once."""


class WithdrawnError(LineError):
    """A request was taken out of the queue before it was sent, because its requester went away
    (an N1 connection closed, a host gave the exchange up); nothing was sent."""
