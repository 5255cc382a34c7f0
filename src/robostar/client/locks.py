"""One exchange at a time, with a fast lane: the locks behind both clients.

A jog's keepalive (BF) must reach the controller within 500 ms of the last one, so it may not
queue behind other callers: an urgent acquirer waits only for the exchange in progress, and
ordinary acquirers step aside while an urgent one waits. Re-entering from the holder (a
progress or trace callback calling the client) would interleave two exchanges on the wire; it
raises UsageError instead of deadlocking.
"""

from __future__ import annotations

import asyncio
import threading
from collections import deque
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager, contextmanager
from threading import get_ident

from robostar.errors import UsageError

__all__ = ["AsyncPriorityLock", "PriorityLock"]

_REENTRY = (
    "the client was called from inside one of its own exchanges (a progress or trace callback);"
    " call it after the exchange instead"
)


class PriorityLock:
    """A thread lock where ``urgent`` acquirers go ahead of ordinary ones."""

    def __init__(self) -> None:
        # The line itself: held by the thread whose exchange runs. Taking it when it is free
        # and nobody urgent waits is one C call, the usual case of every exchange.
        self._line = threading.Lock()
        # Guards the counts of waiters below; the condition waits on it.
        self._mutex = threading.Lock()
        self._cond = threading.Condition(self._mutex)
        self._owner: int | None = None
        self._urgent = 0
        self._waiting = 0  # threads inside the slow path: only they need a notify

    @contextmanager
    def hold(self, *, urgent: bool = False) -> Iterator[None]:
        self.acquire(urgent=urgent)
        try:
            yield
        finally:
            self.release()

    def acquire(self, urgent: bool = False) -> None:
        """Take the lock (an urgent caller ahead of ordinary waiters); pair with
        :meth:`release`. :meth:`hold` does both. (``urgent`` may be positional: every
        exchange passes here, and a keyword costs more.)"""
        me = get_ident()
        if not self._urgent and self._line.acquire(False):
            self._owner = me
            return
        if self._owner == me:
            raise UsageError(_REENTRY)
        with self._mutex:
            if urgent:
                self._urgent += 1
            # Counted before the line is tried: a release after a failed try sees the count
            # and notifies (under the mutex, so not before this thread waits).
            self._waiting += 1
            try:
                while (self._urgent and not urgent) or not self._line.acquire(False):
                    self._cond.wait()
            finally:
                self._waiting -= 1
                if urgent:
                    self._urgent -= 1
                    # Ordinary waiters may go once no urgent one is left.
                    if self._waiting:
                        self._cond.notify_all()
        self._owner = me

    def release(self) -> None:
        self._owner = None
        self._line.release()
        if self._waiting:
            with self._mutex:
                self._cond.notify_all()


class AsyncPriorityLock:
    """The asyncio twin of :class:`PriorityLock` (one event loop; safe between tasks).

    Release hands the lock straight to the next waiter (urgent ones first), so that the
    release path never awaits and a cancelled task cannot leave the lock held.
    """

    def __init__(self) -> None:
        self._owner: asyncio.Task[object] | None = None
        self._held = False
        self._waiters: deque[tuple[bool, asyncio.Future[None]]] = deque()

    @asynccontextmanager
    async def hold(self, *, urgent: bool = False) -> AsyncIterator[None]:
        await self.acquire(urgent=urgent)
        try:
            yield
        finally:
            self._release()

    async def acquire(self, *, urgent: bool = False) -> None:
        """Take the lock; pair with :meth:`release` (:meth:`hold` does both). A cancelled
        wait leaves the lock as it was."""
        me = asyncio.current_task()
        if self._held and me is not None and self._owner is me:
            raise UsageError(_REENTRY)
        if self._held:
            granted: asyncio.Future[None] = asyncio.get_running_loop().create_future()
            entry = (urgent, granted)
            self._waiters.append(entry)
            try:
                await granted
            except BaseException:
                if granted.done() and not granted.cancelled():
                    self._release()  # handed over just as this task was cancelled: pass it on
                elif entry in self._waiters:
                    self._waiters.remove(entry)
                raise
        else:
            self._held = True
        self._owner = me

    def try_acquire(self) -> bool:
        """Take the lock if it is free, without waiting (no coroutine to run); False if it
        is held (then await :meth:`acquire`)."""
        if self._held:
            return False
        self._held = True
        self._owner = asyncio.current_task()
        return True

    def release(self) -> None:
        self._release()

    def _release(self) -> None:
        self._owner = None
        while self._waiters:
            chosen = next((w for w in self._waiters if w[0]), self._waiters[0])
            self._waiters.remove(chosen)
            if not chosen[1].done():  # a cancelled waiter is skipped
                # The lock stays held: it passes to the chosen waiter.
                chosen[1].set_result(None)
                return
        self._held = False
