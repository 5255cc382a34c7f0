"""The lease check of a line's state changes: as one is queued, and again just before it is sent
(it may have waited behind a slow exchange while its requester lost the lease); and the one-shot
lease, taken free for one command and given back as it ends."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from typing import Any

from robostar.commands.base import Command
from robostar.commands.variables import WriteGlobalFloat, WriteGlobalInt, WriteGlobalPoint
from robostar.errors import RobostarError
from robostar.serve.lease import Lease, LeaseHeldError, LeaseInfo, LeaseMode, Who
from robostar.serve.line_queue import STOPS

__all__ = ["SCOPE_COMMANDS", "LeaseGate", "LeaseLostError"]

SCOPE_COMMANDS: dict[str, tuple[type[Command[Any]], ...]] = {
    "globals": (WriteGlobalInt, WriteGlobalFloat, WriteGlobalPoint),
}
"""The state changes of each scope a line may share (its config's ``shared``)."""


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
    line's lease. Stops need none: anyone may stop a robot.

    A one-shot lease (mode ``"once"``: a click, one MQTT command, an OPC UA method) is taken free
    for the command and given back when the last of its holder's one-shot commands ends, success
    or not, unless a jog of its holder still runs (a jog start keeps it until its stop): so a
    single command from a face never locks a host program out for the lease's idle time."""

    def __init__(self, line: str, lease: Lease, shared: frozenset[str] = frozenset()) -> None:
        self.line = line
        self.lease = lease
        self._shared = tuple(kind for scope in shared for kind in SCOPE_COMMANDS[scope])
        self._once_running: Counter[Who] = Counter()
        """One-shot commands admitted and not yet ended, by requester."""

    def needs_lease(self, command: Command[Any]) -> bool:
        """Whether ``command`` needs its requester to hold the lease: a state change, not a
        stop (anyone may stop a robot), not in a scope the line shares (its ``shared``)."""
        if not command.CHANGES_STATE or isinstance(command, STOPS):
            return False
        return not isinstance(command, self._shared)

    def admit(self, who: Who, *, mode: LeaseMode | None) -> bool:
        """As a state change is queued: renew ``who``'s lease, or take a free one for this
        command (``"once"``) or to keep (``"hold"``); None: ``who`` must hold it already.
        LeaseHeldError when another holds it, or it is free and not taken. True when a one-shot
        use began: pair it with :meth:`ended`."""
        if mode is None:
            self.lease.renew(who)
            return False
        self.lease.acquire(who, once=mode == "once")
        if mode == "hold":
            return False
        self._once_running[who] += 1
        return True

    def ended(self, who: Who, *, jogging: Callable[[Who], bool]) -> None:
        """A one-shot command of ``who`` ended (however): the one-shot lease is given back once
        none of ``who``'s one-shot commands is left and no jog of ``who`` runs."""
        self._once_running[who] -= 1
        if self._once_running[who] <= 0:
            del self._once_running[who]
        self.settle(jogging)

    def settle(self, jogging: Callable[[Who], bool]) -> None:
        """Give a one-shot lease back if nothing of its holder needs it any more (after a
        command ends, and after a stop ended its holder's jog)."""
        info = self.lease.holder
        if info is None or not info.once:
            return
        if self._once_running[info.who] or jogging(info.who):
            return
        self._once_running.pop(info.who, None)
        self.lease.release(info.who)

    def refusal_at_send(self, command: Command[Any], who: Who | None) -> LeaseLostError | None:
        """Just before sending: the refusal of ``command`` if it needs ``who``'s lease and
        ``who`` no longer holds it, else None."""
        if who is None or not self.needs_lease(command):
            return None
        if self.lease.held_by(who):
            return None
        return LeaseLostError(self.line, command.CODE, who, self.lease.holder)
