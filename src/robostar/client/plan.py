"""Plans: client operations written once as generators, run by a blocking or an asyncio driver.

A plan yields effects - :class:`Call` (run a command, get its result), :class:`Sleep`, or
:class:`Blocking` (run a function that blocks, such as file work) - and gets each effect's
result sent back (or its error thrown in, KeyboardInterrupt and cancellation included, so that
a plan can end an exchange cleanly). The sync client performs effects by blocking, the asyncio
client by awaiting (a Blocking function in a worker thread, :func:`run_blocking`); the plan
itself never knows which.
:func:`run_plan` and :func:`run_plan_async` are those two loops, for any generator and effect.
"""

from __future__ import annotations

import asyncio
import functools
from collections.abc import Awaitable, Callable, Generator
from dataclasses import dataclass
from typing import Any, Generic, ParamSpec, TypeVar

from robostar.client.exchange import Progress
from robostar.commands.base import Command

__all__ = [
    "Blocking",
    "Call",
    "Effect",
    "Plan",
    "Sleep",
    "blocking",
    "call",
    "run_blocking",
    "run_plan",
    "run_plan_async",
    "sleep",
]

R = TypeVar("R")
E = TypeVar("E")
P = ParamSpec("P")


@dataclass(frozen=True, slots=True)
class Call(Generic[R]):
    """Run ``command`` (with the client's retries and the KD follow-up); the result is sent."""

    command: Command[R]
    progress: Progress | None = None


@dataclass(frozen=True, slots=True)
class Sleep:
    seconds: float


@dataclass(frozen=True, slots=True)
class Blocking(Generic[R]):
    """Run ``function()``, which blocks (file work on this computer); its result is sent.

    The sync client calls it in place; the asyncio client in a worker thread, so that the
    event loop runs on meanwhile. A thread cannot be stopped: when the asyncio task is
    cancelled meanwhile, the function still runs to its end, ``undo(result)`` (if given)
    takes back what it made, which the plan is never told of, and only then is the
    cancellation thrown into the plan.
    """

    function: Callable[[], R]
    undo: Callable[[R], object] | None = None


Effect = Call[Any] | Sleep | Blocking[Any]
Plan = Generator[Effect, Any, R]


def call(command: Command[R], progress: Progress | None = None) -> Plan[R]:
    """``result = yield from call(command)``: the typed way to run a command in a plan."""
    result: R = yield Call(command, progress)
    return result


def sleep(seconds: float) -> Plan[None]:
    yield Sleep(seconds)


def blocking(function: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> Plan[R]:
    """``result = yield from blocking(function, *args)``: run a function that blocks (file
    work) the way the client runs it, never on an event loop."""
    result: R = yield Blocking(functools.partial(function, *args, **kwargs))
    return result


async def run_blocking(effect: Blocking[R]) -> R:
    """The asyncio client's way to perform a :class:`Blocking` effect: in a worker thread,
    waited for to its end even when the task is cancelled meanwhile."""
    work = asyncio.ensure_future(asyncio.to_thread(effect.function))
    try:
        return await asyncio.shield(work)
    except asyncio.CancelledError:
        # The plan cleans up once it sees the cancellation: after the work, not beside it.
        await asyncio.wait([work])
        if effect.undo is not None and not work.cancelled() and work.exception() is None:
            await asyncio.to_thread(effect.undo, work.result())
        raise


class _Reply:
    """What to resume a generator with: a value, or an error to throw into it."""

    __slots__ = ("error", "value")

    def __init__(self, value: object = None, error: BaseException | None = None) -> None:
        self.value = value
        self.error = error

    def resume(self, gen: Generator[E, Any, Any]) -> E:
        if self.error is not None:
            return gen.throw(self.error)
        return gen.send(self.value)


def run_plan(gen: Generator[E, Any, R], perform: Callable[[E], object]) -> R:
    """Run ``gen`` to its end, performing each effect it yields with ``perform``."""
    reply = _Reply()
    try:
        while True:
            try:
                effect = reply.resume(gen)
            except StopIteration as stop:
                result: R = stop.value
                return result
            try:
                reply = _Reply(perform(effect))
            except BaseException as exc:  # Ctrl-C too: the plan may need to clean up
                reply = _Reply(error=exc)
    finally:
        gen.close()


async def run_plan_async(gen: Generator[E, Any, R], perform: Callable[[E], Awaitable[object]]) -> R:
    """The asyncio twin of :func:`run_plan`."""
    reply = _Reply()
    try:
        while True:
            try:
                effect = reply.resume(gen)
            except StopIteration as stop:
                result: R = stop.value
                return result
            try:
                reply = _Reply(await perform(effect))
            except BaseException as exc:  # cancellation too: the plan may need to clean up
                reply = _Reply(error=exc)
    finally:
        gen.close()
