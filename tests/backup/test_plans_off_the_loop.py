"""The backup and the restore do their file work where their client says: in place for the
blocking Client, in a worker thread for AsyncClient, so that a slow disk never holds the event
loop (other tasks run on while the store works). A backup cancelled while the store works
leaves no temporary folder, and the previous backup intact."""

from __future__ import annotations

import asyncio
import functools
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from robostar.backup import store
from robostar.client import AsyncClient, Client

SIM = "sim://?speedup=50"
SLOW = 0.1  # seconds each store operation takes on the slow disk
LOOP_WAIT = 10.0  # how long an operation waits to see the event loop run: a deadlock guard only

STORE_OPERATIONS = (
    "previous_backup",
    "start",
    "write_file",
    "write_manifest",
    "put_in_place",
    "tidy",
    "discard",
    "read_manifest",
    "read_file",
)
"""Every store function the plans ask for."""


class SlowDisk:
    """The store's operations, each made SLOW seconds slower; records which ran on which
    thread and, when ``tick`` is given, whether an event loop ticked while it ran."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, int]] = []
        self.tick: threading.Event | None = None
        self.loop_ran: list[bool] = []

    def slowed(self, name: str, original: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(original)
        def operation(*args: Any, **kwargs: Any) -> Any:
            self.calls.append((name, threading.get_ident()))
            time.sleep(SLOW)
            if self.tick is not None and all(self.loop_ran):
                self.tick.clear()
                self.loop_ran.append(self.tick.wait(LOOP_WAIT))
            return original(*args, **kwargs)

        return operation


@pytest.fixture
def slow_disk(monkeypatch: pytest.MonkeyPatch) -> SlowDisk:
    disk = SlowDisk()
    for name in STORE_OPERATIONS:
        monkeypatch.setattr(store, name, disk.slowed(name, getattr(store, name)))
    return disk


def test_an_async_backup_and_restore_leave_the_event_loop_free(
    slow_disk: SlowDisk, tmp_path: Path
) -> None:
    folder = tmp_path / "bk"
    tick = slow_disk.tick = threading.Event()

    async def main() -> int:
        running = True

        async def ticker() -> None:
            while running:
                await asyncio.sleep(0.01)
                tick.set()

        ticking = asyncio.create_task(ticker())
        async with AsyncClient(SIM) as client:
            manifest = await client.backup(folder)
            assert manifest.folder == str(folder) and manifest.files
            await client.restore(folder)
        running = False
        await ticking
        return threading.get_ident()

    loop_thread = asyncio.run(main())
    names = {name for name, _ in slow_disk.calls}
    assert names >= set(STORE_OPERATIONS) - {"discard"}  # a backup that succeeds discards none
    assert all(thread != loop_thread for _, thread in slow_disk.calls)
    assert slow_disk.loop_ran and all(slow_disk.loop_ran)  # the loop ran during each operation
    assert (folder / "manifest.json").exists()


def test_a_blocking_client_does_the_file_work_in_place(slow_disk: SlowDisk, tmp_path: Path) -> None:
    folder = tmp_path / "bk"
    with Client(SIM) as client:
        client.backup(folder)
        client.restore(folder)
    assert {name for name, _ in slow_disk.calls} >= {"start", "write_file", "read_file"}
    assert {thread for _, thread in slow_disk.calls} == {threading.get_ident()}


class Gate:
    """Holds one store operation until released, to cancel a backup while it runs."""

    def __init__(self) -> None:
        self.entered = threading.Event()
        self.release = threading.Event()

    def hold(self, original: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(original)
        def operation(*args: Any, **kwargs: Any) -> Any:
            self.entered.set()
            assert self.release.wait(LOOP_WAIT)
            return original(*args, **kwargs)

        return operation


@pytest.mark.parametrize("operation", ["start", "write_file", "write_manifest"])
def test_a_backup_cancelled_while_the_store_works_leaves_nothing(
    operation: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "bk"
    gate = Gate()

    async def main() -> None:
        async with AsyncClient(SIM) as client:
            await client.backup(folder)  # the previous backup
            before = (folder / "manifest.json").read_bytes()
            monkeypatch.setattr(store, operation, gate.hold(getattr(store, operation)))
            backup = asyncio.create_task(client.backup(folder))
            assert await asyncio.to_thread(gate.entered.wait, LOOP_WAIT)
            backup.cancel()
            await asyncio.sleep(0)
            gate.release.set()
            with pytest.raises(asyncio.CancelledError):
                await backup
            assert (folder / "manifest.json").read_bytes() == before

    asyncio.run(main())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bk"]  # no temporary folder left
