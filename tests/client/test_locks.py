"""The client locks: one holder, urgent acquirers first, no re-entry, cancellation-safe."""

from __future__ import annotations

import asyncio
import threading
import time

import pytest

from robostar.client.locks import AsyncPriorityLock, PriorityLock
from robostar.errors import UsageError

pytestmark = pytest.mark.timeout(20)


def test_an_urgent_acquirer_goes_before_ordinary_waiters() -> None:
    lock = PriorityLock()
    order: list[str] = []
    release = threading.Event()

    def take(name: str, urgent: bool) -> None:
        with lock.hold(urgent=urgent):
            order.append(name)

    def holder() -> None:
        with lock.hold():
            release.wait()

    first = threading.Thread(target=holder)
    first.start()
    time.sleep(0.05)
    ordinary = [threading.Thread(target=take, args=(f"o{i}", False)) for i in range(3)]
    for thread in ordinary:
        thread.start()
    time.sleep(0.05)
    urgent = threading.Thread(target=take, args=("urgent", True))
    urgent.start()
    time.sleep(0.05)
    release.set()
    for thread in [first, *ordinary, urgent]:
        thread.join()
    assert order[0] == "urgent" and sorted(order[1:]) == ["o0", "o1", "o2"]


def test_re_entering_from_the_holder_is_refused() -> None:
    lock = PriorityLock()
    with (
        lock.hold(),
        pytest.raises(UsageError, match="inside one of its own exchanges"),
        lock.hold(urgent=True),
    ):
        pass
    with lock.hold():  # and the lock is free again
        pass


def test_async_urgent_first_and_no_re_entry() -> None:
    async def main() -> list[str]:
        lock = AsyncPriorityLock()
        order: list[str] = []

        async def take(name: str, urgent: bool) -> None:
            async with lock.hold(urgent=urgent):
                order.append(name)

        async with lock.hold():
            tasks = [asyncio.create_task(take(f"o{i}", False)) for i in range(3)]
            await asyncio.sleep(0)
            tasks.append(asyncio.create_task(take("urgent", True)))
            await asyncio.sleep(0)
            with pytest.raises(UsageError):
                async with lock.hold():
                    pass
        await asyncio.gather(*tasks)
        return order

    assert asyncio.run(main()) == ["urgent", "o0", "o1", "o2"]


def test_async_cancelled_waiters_never_leave_the_lock_held() -> None:
    # Regression: a waiter cancelled after the holder picked it used to get set_result on a
    # cancelled future (InvalidStateError) and the lock stayed held for ever.
    async def main() -> None:
        lock = AsyncPriorityLock()

        async def user() -> None:
            while True:
                async with lock.hold():
                    await asyncio.sleep(0)

        tasks = [asyncio.create_task(user()) for _ in range(4)]
        await asyncio.sleep(0.05)
        for task in tasks:
            task.cancel()
        results = await asyncio.gather(*tasks, return_exceptions=True)
        assert all(isinstance(r, asyncio.CancelledError) for r in results), results
        async with asyncio.timeout(1):
            async with lock.hold():
                pass

    asyncio.run(main())


def test_async_a_waiter_cancelled_while_waiting_is_skipped() -> None:
    async def main() -> None:
        lock = AsyncPriorityLock()
        got: list[str] = []

        async def take(name: str) -> None:
            async with lock.hold():
                got.append(name)

        async with lock.hold():
            doomed = asyncio.create_task(take("doomed"))
            kept = asyncio.create_task(take("kept"))
            await asyncio.sleep(0)
            doomed.cancel()
            await asyncio.sleep(0)
        await kept
        assert got == ["kept"] and doomed.cancelled()

    asyncio.run(main())
