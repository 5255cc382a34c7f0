"""Plans: client operations written once as generators, run by a blocking or an asyncio driver.

A plan yields effects - :class:`Call` (run a command, get its result) or :class:`Sleep` - and
gets each effect's result sent back (or its error thrown in, KeyboardInterrupt and
cancellation included, so that a plan can end an exchange cleanly). The sync client performs effects
by blocking, the asyncio client by awaiting; the plan itself never knows which.
:func:`run_plan` and :func:`run_plan_async` are those two loops, for any generator and effect.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Generator
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from robostar.client.exchange import Progress
from robostar.commands.base import Command

__all__ = ["Call", "Effect", "Plan", "Sleep", "call", "run_plan", "run_plan_async", "sleep"]

R = TypeVar("R")
E = TypeVar("E")


@dataclass(frozen=True, slots=True)
class Call(Generic[R]):
    """Run ``command`` (with the client's retries and the KD follow-up); the result is sent."""

    command: Command[R]
    progress: Progress | None = None


@dataclass(frozen=True, slots=True)
class Sleep:
    seconds: float


Effect = Call[Any] | Sleep
Plan = Generator[Effect, Any, R]


def call(command: Command[R], progress: Progress | None = None) -> Plan[R]:
    """``result = yield from call(command)``: the typed way to run a command in a plan."""
    result: R = yield Call(command, progress)
    return result


def sleep(seconds: float) -> Plan[None]:
    yield Sleep(seconds)


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
