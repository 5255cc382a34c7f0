"""Binding plans to the two clients, with precise types for both.

A method of the command surface is written once, as a plan (a generator, see
:mod:`robostar.client.plan`), and decorated with :class:`operation`. Read from a
:class:`SyncRunner` it is a plain method returning the result; read from an
:class:`AsyncRunner` it is a coroutine method. mypy sees both through the overloads of
``__get__``, parameters and result type included.
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from collections.abc import Callable, Coroutine
from typing import Any, Concatenate, Generic, ParamSpec, Self, TypeVar, cast, overload

from robostar.client.plan import Plan

__all__ = ["AsyncRunner", "SyncRunner", "operation"]

P = ParamSpec("P")
R = TypeVar("R")


class SyncRunner(ABC):
    """A client that runs plans by blocking."""

    @abstractmethod
    def _run(self, plan: Plan[R]) -> R:
        """Run a plan to its end and return its result."""


class AsyncRunner(ABC):
    """A client that runs plans on an asyncio event loop."""

    @abstractmethod
    async def _run(self, plan: Plan[R]) -> R:
        """Run a plan to its end and return its result."""


class operation(Generic[P, R]):  # lower case: used as a decorator, like property
    """Decorator: a plan method becomes a sync method on a SyncRunner, async on an
    AsyncRunner."""

    def __init__(self, plan: Callable[Concatenate[Any, P], Plan[R]]) -> None:
        self.plan = plan
        functools.update_wrapper(cast(Any, self), plan)

    @overload
    def __get__(self, obj: None, owner: type[Any] | None = None) -> Self: ...

    @overload
    def __get__(self, obj: SyncRunner, owner: type[Any] | None = None) -> Callable[P, R]: ...

    @overload
    def __get__(
        self, obj: AsyncRunner, owner: type[Any] | None = None
    ) -> Callable[P, Coroutine[Any, Any, R]]: ...

    def __get__(self, obj: object, owner: type[Any] | None = None) -> Any:
        if obj is None:
            return self
        plan = self.plan
        if isinstance(obj, AsyncRunner):
            runner = obj

            @functools.wraps(plan)
            async def run_async(*args: Any, **kwargs: Any) -> Any:
                return await runner._run(plan(runner, *args, **kwargs))

            return run_async
        if isinstance(obj, SyncRunner):
            sync = obj

            @functools.wraps(plan)
            def run(*args: Any, **kwargs: Any) -> Any:
                return sync._run(plan(sync, *args, **kwargs))

            return run
        raise TypeError(f"{self.plan.__name__} needs a Client or an AsyncClient")
