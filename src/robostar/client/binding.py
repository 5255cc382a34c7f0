"""How the command surface becomes the two clients' methods.

A method of the command surface is written once, as a plan (a generator, see
:mod:`robostar.client.plan`), in :class:`robostar.client.surface.Operations`, and marked with
:func:`operation`. ``tools/generate_faces.py`` writes a real method for each on both clients
(``robostar/client/_sync_face.py``, ``_async_face.py``): ``def status(self) -> AllStatus`` and
``async def status(self) -> AllStatus``, with the plan's parameters, defaults and docstring, so
that help(), inspect, ``unittest.mock.create_autospec``, IDEs and mypy see the call a user
makes. Each runs its plan with the client's :meth:`_run`; a plan that is a single command
(``return (yield from call(X))``) becomes a direct ``self._call(X)``. There is no wrapper per
call.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

from robostar.client.exchange import Progress
from robostar.client.plan import Plan
from robostar.commands.base import Command

__all__ = ["AsyncRunner", "SyncRunner", "is_operation", "operation", "operations"]

R = TypeVar("R")
F = TypeVar("F", bound=Callable[..., Any])

_MARK = "__robostar_operation__"


class SyncRunner(ABC):
    """A client that runs plans by blocking."""

    @abstractmethod
    def _run(self, plan: Plan[R]) -> R:
        """Run a plan to its end and return its result."""

    @abstractmethod
    def _call(
        self, command: Command[R], progress: Progress | None = None, *, urgent: bool = False
    ) -> R:
        """Run one command (a plan that is one ``call``, without the plan)."""


class AsyncRunner(ABC):
    """A client that runs plans on an asyncio event loop."""

    @abstractmethod
    async def _run(self, plan: Plan[R]) -> R:
        """Run a plan to its end and return its result."""

    @abstractmethod
    async def _call(
        self, command: Command[R], progress: Progress | None = None, *, urgent: bool = False
    ) -> R:
        """Run one command (a plan that is one ``call``, without the plan)."""


def operation(plan: F) -> F:
    """Mark a plan method of the surface as a client operation (the plan is unchanged)."""
    setattr(plan, _MARK, True)
    return plan


def is_operation(value: object) -> bool:
    return callable(value) and getattr(value, _MARK, False) is True


def operations(cls: type) -> Iterator[tuple[str, Callable[..., Any]]]:
    """The operations of ``cls`` in the order they are written."""
    for name, value in vars(cls).items():
        if is_operation(value):
            yield name, value
