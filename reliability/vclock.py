"""A virtual clock for the blocking client and the in-memory transport: sleeping costs nothing.

Client, in-memory transport and simulator run in one thread and read the time only through
``time.monotonic()`` and ``time.sleep()`` (the simulator is given the time by its transport), so
swapping the ``time`` of every client and transport module for a :class:`VirtualClock` runs the
real code with every timeout, resend and motion exactly as in real time, without waiting for it.
A run is then repeatable to the byte, and "raised within its timeout" is measured, not guessed.
:class:`Hang` ends a run that would never finish.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Iterator
from types import ModuleType, SimpleNamespace

__all__ = [
    "PATCHED_PACKAGES",
    "Hang",
    "RealClock",
    "VirtualClock",
    "patched_modules",
    "virtual_time",
]

PATCHED_PACKAGES = ("robostar.client", "robostar.transport")
"""The packages on the matrix's path whose clock reads the virtual clock stands in for."""


def patched_modules() -> list[ModuleType]:
    """Every loaded module of those packages that imported ``time`` (found afresh each time, so
    that code moved between modules is still covered)."""
    return [
        module
        for name, module in sorted(sys.modules.items())
        if name.startswith(PATCHED_PACKAGES) and getattr(module, "time", None) is time
    ]


class Hang(BaseException):
    """The run went past its budget of virtual time or of clock reads without finishing.

    A BaseException, so that no ``except Exception`` in the code under test can swallow it.
    """


class VirtualClock:
    """Monotonic seconds that move only when someone sleeps."""

    def __init__(self, start: float = 1000.0, *, budget: float = 600.0) -> None:
        self.now = start
        self.budget = budget
        self.reads = 0
        self._limit = start + budget
        self._read_limit = 5_000_000

    def arm(self, budget: float, reads: int = 2_000_000) -> None:
        """From now on, raise :class:`Hang` after ``budget`` more seconds or ``reads`` reads."""
        self.budget = budget
        self._limit = self.now + budget
        self._read_limit = self.reads + reads

    def monotonic(self) -> float:
        self.reads += 1
        if self.reads > self._read_limit:
            raise Hang(f"clock read {self.reads} times without finishing (a busy loop)")
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += max(float(seconds), 0.0)
        if self.now > self._limit:
            raise Hang(f"still running {self.budget:g} s of virtual time later")

    def time(self) -> float:
        return time.time()


class RealClock(VirtualClock):
    """The same interface on the real clock, to check that the virtual one changes nothing."""

    def __init__(self, *, budget: float = 600.0) -> None:
        super().__init__(time.monotonic(), budget=budget)

    @property
    def now(self) -> float:
        return time.monotonic()

    @now.setter
    def now(self, value: float) -> None:
        """The real clock is not set; the base class's start value is ignored."""

    def sleep(self, seconds: float) -> None:
        time.sleep(max(float(seconds), 0.0))
        if self.now > self._limit:
            raise Hang(f"still running {self.budget:g} s later")


@contextlib.contextmanager
def virtual_time(clock: VirtualClock) -> Iterator[VirtualClock]:
    """Run the client, the in-memory transport and the waits on ``clock`` (a RealClock leaves
    the modules as they are)."""
    if isinstance(clock, RealClock):
        yield clock
        return
    shim = SimpleNamespace(monotonic=clock.monotonic, sleep=clock.sleep, time=clock.time)
    saved = [(module, module.time) for module in patched_modules()]
    try:
        for module, _ in saved:
            module.time = shim  # type: ignore[attr-defined]
        yield clock
    finally:
        for module, original in saved:
            module.time = original  # type: ignore[attr-defined]
