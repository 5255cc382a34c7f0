"""Single-flight reads: identical reads waiting together share one wire exchange.

A read joins the *flight* of an identical read (same command, equal parameters) that is still
waiting in the queue; one already taken by the worker (its request may be on the wire) is never
joined, since its answer may describe the controller before the read arrived: the read starts
the next flight instead. Every answer is thus from an exchange that began after its read
arrived (a linearizable read), and many readers of the same thing cost one exchange per turn
of the wire, whatever their number.

The poller's reads are flights like any other, so a consumer's read waiting with a poll read is
answered by it, and every flight's answer refreshes the model (``on_answer``). A flight waits
at the most urgent priority of its readers: a consumer joining a poll read raises it to a
consumer's read. A reader that goes away (cancelled, withdrawn) leaves its flight; a flight
nobody waits for any more is dropped before it is sent.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Hashable
from typing import Any

from robostar.commands.base import Command
from robostar.serve.lease import Who
from robostar.serve.line_queue import Job

__all__ = ["Flight", "ReadFlights"]

Enqueue = Callable[[Command[Any], int], Job]
"""Queue a command at a priority (shared: no requester of its own); the job to follow."""
OnAnswer = Callable[[Command[Any], Any, float], None]
"""Called with a flight's command, its answer and the ``time.time()`` its exchange began."""


class Flight:
    """One exchange shared by the readers waiting for it."""

    def __init__(self, command: Command[Any], job: Job) -> None:
        self.command = command
        self.job = job
        self.readers: list[tuple[asyncio.Future[Any], Who | None]] = []

    def requester(self) -> Who | None:
        """The one requester all its readers are (None: the poller's, or several)."""
        whos = {who for reader, who in self.readers if not reader.cancelled()}
        return whos.pop() if len(whos) == 1 else None

    @property
    def boarding(self) -> bool:
        """Still waiting in the queue: a read arriving now may join it."""
        return not self.job.started and not self.job.future.done()


class ReadFlights:
    """The line's reads, coalesced into flights (see the module docstring)."""

    def __init__(self, enqueue: Enqueue, on_answer: OnAnswer) -> None:
        self._enqueue = enqueue
        self._on_answer = on_answer
        self._boarding: dict[Hashable, Flight] = {}
        self.flights = 0
        """Flights sent (or failed) since start: exchanges the reads cost."""
        self.reads = 0
        """Reads answered by a flight since start (the poller's included)."""

    def read(self, command: Command[Any], priority: int, who: Who | None) -> asyncio.Future[Any]:
        """A future of ``command``'s answer, with the ``time.time()`` its exchange began: an
        exchange that begins after this call."""
        key = _key(command)
        flight = self._boarding.get(key) if key is not None else None
        if flight is None or not flight.boarding:
            flight = self._take_off(command, priority)
            if key is not None:
                self._boarding[key] = flight
        elif priority < flight.job.priority:
            self._rebook(flight, priority)
        reader: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        flight.readers.append((reader, who))
        reader.add_done_callback(lambda _: self._left(flight, reader))
        return reader

    def hurry(self, command: Command[Any], priority: int) -> None:
        """Raise the waiting flight of ``command`` (if any) to ``priority`` (a poll read that
        would let the model go stale)."""
        key = _key(command)
        flight = self._boarding.get(key) if key is not None else None
        if flight is not None and flight.boarding and priority < flight.job.priority:
            self._rebook(flight, priority)

    def withdraw(self, who: Who, error: Callable[[Command[Any]], BaseException]) -> int:
        """Fail ``who``'s reads still waiting in the queue with ``error(command)``; the count."""
        withdrawn = 0
        for flight in list(self._boarding.values()):
            if not flight.boarding:
                continue
            for reader, whose in list(flight.readers):
                if whose == who and not reader.done():
                    reader.set_exception(error(flight.command))
                    withdrawn += 1
        return withdrawn

    def _take_off(self, command: Command[Any], priority: int) -> Flight:
        flight = Flight(command, self._enqueue(command, priority))
        self._watch(flight)
        return flight

    def _rebook(self, flight: Flight, priority: int) -> None:
        """Queue the flight again at ``priority``; the worker skips its old (cancelled) job."""
        old = flight.job
        flight.job = self._enqueue(flight.command, priority)
        old.future.cancel()
        self._watch(flight)

    def _watch(self, flight: Flight) -> None:
        job = flight.job
        job.shared_by = flight.requester
        job.future.add_done_callback(lambda future: self._landed(flight, job, future))

    def _landed(self, flight: Flight, job: Job, future: asyncio.Future[Any]) -> None:
        if job is not flight.job:
            return  # a job rebooked at another priority: the flight follows the new one
        key = _key(flight.command)
        if key is not None and self._boarding.get(key) is flight:
            del self._boarding[key]
        if future.cancelled():
            if job.started:  # a bug's way out only: never leave a reader waiting for ever
                for reader, _ in flight.readers:
                    if not reader.done():
                        reader.cancel()
            return
        self.flights += 1
        error = future.exception()
        if error is None:
            self._on_answer(flight.command, future.result(), job.began)
        for reader, _ in flight.readers:
            if reader.done():
                continue
            self.reads += 1
            if error is None:
                reader.set_result((future.result(), job.began))
            else:
                reader.set_exception(error)

    def _left(self, flight: Flight, reader: asyncio.Future[Any]) -> None:
        """A reader got its answer or went away; a waiting flight nobody wants is dropped."""
        if flight.boarding and all(r.done() for r, _ in flight.readers):
            flight.job.future.cancel()  # the worker skips it: nothing is sent


def _key(command: Command[Any]) -> Hashable | None:
    """What makes two reads the same read (None: never shared)."""
    try:
        hash(command)
    except TypeError:
        return None
    return command
