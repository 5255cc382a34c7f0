"""The client locks: one holder, urgent acquirers first, no re-entry, cancellation-safe."""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable

import pytest

from robostar.client.locks import AsyncPriorityLock, PriorityLock
from robostar.errors import UsageError

pytestmark = pytest.mark.timeout(20)


def _until(condition: Callable[[], bool], timeout: float = 5.0) -> None:
    """Wait (spinning, 1 ms naps) until ``condition`` holds; fail after ``timeout``."""
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.001)


def test_an_urgent_acquirer_goes_before_ordinary_waiters() -> None:
    lock = PriorityLock()
    order: list[str] = []
    held, release = threading.Event(), threading.Event()

    def take(name: str, urgent: bool) -> None:
        with lock.hold(urgent=urgent):
            order.append(name)

    def holder() -> None:
        with lock.hold():
            held.set()
            release.wait()

    first = threading.Thread(target=holder)
    first.start()
    assert held.wait(5)
    ordinary = [threading.Thread(target=take, args=(f"o{i}", False)) for i in range(3)]
    for thread in ordinary:
        thread.start()
    _until(lambda: lock._waiting == 3)  # all three wait: none can have gone before
    urgent = threading.Thread(target=take, args=("urgent", True))
    urgent.start()
    _until(lambda: lock._waiting == 4)
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


# -- Ctrl-C at any point (issue #11) ----------------------------------------------------------
def test_ctrl_c_at_any_moment_never_breaks_a_shared_clients_lock() -> None:
    # The main thread calls the client over and over while a timer interrupts it (as Ctrl-C
    # does) at every kind of moment; four other threads share the client all along. No
    # interrupt may leave the lock held or raise "release unlocked lock", and every thread's
    # next call works. (The simulator is served from its own thread, as a real controller is
    # out of reach of the host's Ctrl-C.)
    import _thread
    import random

    from robostar import Client
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.listeners import SimServer

    stop = threading.Event()
    errors: list[BaseException] = []
    done = [0, 0, 0, 0]
    interrupts = 0

    with SimServer(VirtualController(SimConfig())) as server:
        client = Client(server.url, timeout=0.5)

        def worker(slot: int) -> None:
            while not stop.is_set():
                try:
                    client.status()
                    done[slot] += 1
                except Exception as exc:
                    errors.append(exc)
                    return

        go = threading.Event()

        def interrupter() -> None:
            rng = random.Random(7)
            # not before the main thread is inside its try: an interrupt that landed while it
            # still started the threads would end the test run itself, not the call under test
            go.wait()
            for _ in range(600):
                time.sleep(rng.uniform(0.0, 0.002))
                _thread.interrupt_main()
            stop.set()

        def calls() -> None:
            nonlocal interrupts
            while not stop.is_set():
                try:
                    client.status()
                except KeyboardInterrupt:
                    interrupts += 1

        threads = [threading.Thread(target=worker, args=(i,)) for i in range(len(done))]
        threads.append(threading.Thread(target=interrupter))
        for thread in threads:
            thread.start()
        while not stop.is_set():
            try:
                go.set()
                calls()
            except KeyboardInterrupt:  # one landed between the loop's own bytecodes
                interrupts += 1
        for thread in threads:
            thread.join(10)
        try:
            time.sleep(0.05)  # an interrupt still pending lands here
        except KeyboardInterrupt:
            interrupts += 1
        try:
            assert not errors, errors[:3]
            assert interrupts > 50
            assert all(n > 0 for n in done)
            started = time.monotonic()
            assert client.status()[0].ready  # the lock is free and the link is in step
            assert time.monotonic() - started < 2.0
        finally:
            client.close()


def test_cancelling_tasks_at_any_moment_never_breaks_a_shared_async_client() -> None:
    import random

    from robostar import AsyncClient
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.listeners import SimServer

    async def main(url: str) -> tuple[int, int]:
        rng = random.Random(3)
        cancelled = finished = 0
        async with AsyncClient(url, timeout=0.5) as client:

            async def calls() -> None:
                while True:
                    await client.status()

            tasks = [asyncio.create_task(calls()) for _ in range(4)]
            for _ in range(300):
                await asyncio.sleep(rng.uniform(0.0, 0.003))
                k = rng.randrange(len(tasks))
                tasks[k].cancel()
                try:
                    await tasks[k]
                except asyncio.CancelledError:
                    cancelled += 1
                tasks[k] = asyncio.create_task(calls())
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
            started = time.monotonic()
            assert (await client.status())[0].ready
            assert time.monotonic() - started < 2.0
            finished = 1
        return cancelled, finished

    with SimServer(VirtualController(SimConfig())) as server:
        cancelled, finished = asyncio.run(main(server.url))
    assert cancelled == 300 and finished == 1


def test_threads_hammering_the_lock_never_overlap_and_never_stall() -> None:
    # The fast path (one C call when free) and the slow path (waiters, urgent first) mixed:
    # at most one holder at any time, every acquire served, no lost wake-up (a stall would
    # hit the timeout).
    lock = PriorityLock()
    inside = 0
    overlaps = 0
    served = [0] * 6

    def work(index: int) -> None:
        nonlocal inside, overlaps
        urgent = index == 0
        for _ in range(2000):
            lock.acquire(urgent=urgent)
            try:
                inside += 1
                if inside != 1:
                    overlaps += 1
                if not served[index] % 50:
                    time.sleep(0)  # hand the GIL over while holding, now and then
                inside -= 1
                served[index] += 1
            finally:
                lock.release()

    threads = [threading.Thread(target=work, args=(i,)) for i in range(len(served))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(15)
    assert not any(thread.is_alive() for thread in threads)
    assert overlaps == 0 and served == [2000] * len(served)
    with lock.hold(urgent=True):  # and it is free at the end
        pass
