"""The Blocking effect of a plan: the blocking Client runs its function in place, the
AsyncClient in a worker thread; its result is sent into the plan and its error thrown in; an
asyncio task cancelled meanwhile waits for the function to end, undoes what it made, and only
then throws the cancellation into the plan."""

from __future__ import annotations

import asyncio
import threading
from typing import Any

import pytest

from robostar.client import AsyncClient, Client
from robostar.client.plan import Blocking, Plan, blocking

SIM = "sim://?speedup=50"


def _where(tag: str) -> tuple[str, int]:
    return tag, threading.get_ident()


def _fails() -> None:
    raise OSError("the disk is gone")


def _caught() -> Plan[str]:
    try:
        yield from blocking(_fails)
    except OSError as exc:
        return f"caught: {exc}"
    return "not raised"


def test_the_blocking_client_runs_it_in_place() -> None:
    with Client(SIM) as client:
        assert client._run(blocking(_where, "here")) == ("here", threading.get_ident())
        assert client._run(_caught()) == "caught: the disk is gone"


def test_the_asyncio_client_runs_it_in_a_worker_thread() -> None:
    async def main() -> tuple[tuple[str, int], int, str]:
        async with AsyncClient(SIM) as client:
            result = await client._run(blocking(_where, "there"))
            return result, threading.get_ident(), await client._run(_caught())

    (tag, thread), loop_thread, caught = asyncio.run(main())
    assert tag == "there" and thread != loop_thread
    assert caught == "caught: the disk is gone"


def test_a_cancelled_task_waits_for_the_function_and_undoes_it() -> None:
    entered, release = threading.Event(), threading.Event()
    events: list[str] = []

    def make() -> str:
        entered.set()
        assert release.wait(10.0)
        events.append("made")
        return "folder"

    def undo(made: str) -> None:
        events.append(f"undone {made}")

    def plan() -> Plan[None]:
        try:
            yield Blocking(make, undo)
        except asyncio.CancelledError:
            events.append("cancellation seen")
            raise

    async def main() -> None:
        async with AsyncClient(SIM) as client:
            task: asyncio.Task[Any] = asyncio.create_task(client._run(plan()))
            assert await asyncio.to_thread(entered.wait, 10.0)
            task.cancel()
            await asyncio.sleep(0)
            release.set()
            with pytest.raises(asyncio.CancelledError):
                await task

    asyncio.run(main())
    assert events == ["made", "undone folder", "cancellation seen"]
