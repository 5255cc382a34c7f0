"""The lease check of a line's state changes: as one is queued, and again just before it is sent
(it may have waited behind a slow exchange while its requester lost the lease)."""

from __future__ import annotations

from typing import Any

from robostar.commands.base import Command
from robostar.errors import RobostarError
from robostar.serve.lease import Lease, LeaseHeldError, LeaseInfo, Who
from robostar.serve.line_queue import STOPS

__all__ = ["LeaseGate", "LeaseLostError"]


class LeaseLostError(LeaseHeldError):
    """A state change waited in the queue while its requester lost the lease (expiry, release,
    a disconnect, a takeover); it was refused just before sending: nothing was sent.

    A :class:`LeaseHeldError`, so faces answer it as they answer any lease conflict."""

    def __init__(self, line: str, command: str, who: Who, holder: LeaseInfo | None) -> None:
        now = f"control is held by {holder.who}" if holder is not None else "the lease is free"
        # not LeaseHeldError's own text ("control is held by ..."): the point is the loss
        RobostarError.__init__(
            self,
            f"line {line}: {command} for {who} refused: the lease was lost before it was sent"
            f" ({now}); nothing was sent",
        )
        self.line = line
        self.holder = holder  # None: the lease is free, as LeaseHeldError has it


class LeaseGate:
    """Admits ``who``'s state changes to the queue, and to the wire, while ``who`` holds the
    line's lease. Stops need none: anyone may stop a robot."""

    def __init__(self, line: str, lease: Lease) -> None:
        self.line = line
        self.lease = lease

    def admit(self, who: Who, *, implicit_lease: bool) -> None:
        """As a state change is queued: renew ``who``'s lease, or take it (``implicit_lease``,
        or already held); LeaseHeldError when another holds it or it is free and not taken."""
        if self.lease.held_by(who) or implicit_lease:
            self.lease.acquire(who)
        else:
            self.lease.renew(who)

    def refusal_at_send(self, command: Command[Any], who: Who | None) -> LeaseLostError | None:
        """Just before sending: the refusal of ``command`` if it needs ``who``'s lease and
        ``who`` no longer holds it, else None."""
        if who is None or not command.CHANGES_STATE or isinstance(command, STOPS):
            return None
        if self.lease.held_by(who):
            return None
        return LeaseLostError(self.line, command.CODE, who, self.lease.holder)
