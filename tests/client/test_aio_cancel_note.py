"""A cancelled asyncio call: the CancelledError propagates, and a state change says its outcome.

Cancelling a task is asyncio's business: the client never swallows nor replaces the
CancelledError. But a state change cancelled mid-exchange leaves the caller not knowing whether
the controller carried it out, as a lost answer does (OutcomeUnknownError). So the error gets a
PEP 678 note naming the command and saying whether it may have been carried out, and the same
is logged at WARNING on the ``robostar`` logger. A read cancelled needs no note.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Awaitable, Callable, Iterator
from typing import Any

import pytest

from robostar import AsyncClient
from robostar.sim.config import SimConfig
from robostar.sim.controller import VirtualController
from robostar.sim.listeners import SimServer

from .delay_relay import DelayRelay

TIMEOUT = 1.0  # the quiet gap after the client's own abort, for reads and writes


def _notes(exc: BaseException) -> list[str]:
    return list(getattr(exc, "__notes__", []))


async def _cancel_after(
    call: Callable[[], Awaitable[Any]], seconds: float
) -> asyncio.CancelledError:
    """Start ``call`` in a task, cancel it after ``seconds``; the CancelledError it raised."""
    task = asyncio.create_task(call())
    await asyncio.sleep(seconds)
    task.cancel()
    with pytest.raises(asyncio.CancelledError) as info:
        await task
    assert task.cancelled()  # asyncio's semantics: the task ends cancelled
    return info.value


def _warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [
        r.getMessage()
        for r in caplog.records
        if r.name == "robostar" and r.levelno == logging.WARNING
    ]


def test_a_state_change_cancelled_after_its_request_went_out_says_the_outcome_is_unknown(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # DB (servo on) is two-phase: the simulator takes 0.3 s between its answers, so at 0.1 s
    # the request is out and the first answer in; the controller may well carry it out.
    caplog.set_level(logging.WARNING, logger="robostar")

    async def run() -> tuple[asyncio.CancelledError, bool]:
        async with AsyncClient("sim://", timeout=TIMEOUT) as client:
            error = await _cancel_after(lambda: client.servo(1, True), 0.1)
            await asyncio.sleep(0.5)
            return error, (await client.status())[0].servo_on

    error, servo_on = asyncio.run(run())
    [note] = _notes(error)
    assert "DB (Servo)" in note
    assert "after its request was sent: the outcome is unknown" in note
    assert _warnings(caplog) == [note]
    assert servo_on  # the simulator did carry it out: the note was right to doubt


def test_a_state_change_cancelled_before_its_request_went_out_says_not_carried_out(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # After the client's own abort a write waits the whole quiet gap (TIMEOUT) before its
    # request goes out: cancelled meanwhile, it was never sent.
    caplog.set_level(logging.WARNING, logger="robostar")

    async def run() -> tuple[asyncio.CancelledError, int]:
        async with AsyncClient("sim://", timeout=TIMEOUT) as client:
            await client.write_global_int(7, 1)
            await _cancel_after(lambda: client.servo(1, True), 0.1)
            caplog.clear()
            error = await _cancel_after(lambda: client.write_global_int(7, 2), 0.2)
            return error, await client.read_global_int(7)

    error, value = asyncio.run(run())
    [note] = _notes(error)
    assert "GW (WriteGlobalInt)" in note
    assert "before its request was sent: not carried out" in note
    assert _warnings(caplog) == [note]
    assert value == 1  # and it was not


def test_a_read_cancelled_in_the_gap_has_no_note(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING, logger="robostar")

    async def run() -> asyncio.CancelledError:
        async with AsyncClient("sim://", timeout=TIMEOUT) as client:
            await _cancel_after(lambda: client.servo(1, True), 0.1)
            caplog.clear()
            return await _cancel_after(lambda: client.read_global_int(7), 0.2)

    error = asyncio.run(run())
    assert _notes(error) == []
    assert _warnings(caplog) == []


@pytest.fixture
def slow_line() -> Iterator[str]:
    """The simulator over TCP, every chunk held 0.3 s each way: requests are on the wire a
    while before their answers come."""
    with SimServer(VirtualController(SimConfig())) as server:
        relay = DelayRelay(server.address, 0.3)
        yield relay.url
        relay.close()


def test_a_read_cancelled_mid_exchange_has_no_note(
    slow_line: str, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, logger="robostar")

    async def run() -> asyncio.CancelledError:
        async with AsyncClient(slow_line, timeout=TIMEOUT) as client:
            return await _cancel_after(lambda: client.read_global_int(7), 0.1)

    error = asyncio.run(run())
    assert _notes(error) == []
    assert _warnings(caplog) == []


def test_a_write_cancelled_mid_exchange_says_the_outcome_is_unknown(
    slow_line: str, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, logger="robostar")

    async def run() -> tuple[asyncio.CancelledError, int]:
        async with AsyncClient(slow_line, timeout=TIMEOUT) as client:
            error = await _cancel_after(lambda: client.write_global_int(7, 5), 0.1)
            return error, await client.read_global_int(7)

    error, value = asyncio.run(run())
    [note] = _notes(error)
    assert "GW (WriteGlobalInt)" in note
    assert "the outcome is unknown" in note
    assert _warnings(caplog) == [note]
    assert value == 5  # the request was on its way: the controller carried it out


def test_the_cancellation_is_not_swallowed_by_a_waiting_caller() -> None:
    # asyncio.wait_for's timeout is built on cancellation: it must still see it and raise.
    async def run() -> None:
        async with AsyncClient("sim://", timeout=TIMEOUT) as client:
            with pytest.raises(TimeoutError):
                await asyncio.wait_for(client.servo(1, True), 0.1)

    asyncio.run(run())


def test_a_state_change_cancelled_after_its_answer_was_taken_says_carried_out(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The asyncio client takes and ACKs a clean answer in the transport's callback; a cancel
    landing in that same loop turn meets a finished exchange: carried out, and nothing else
    is sent (no RST)."""
    from robostar.client import exchange as exchange_module

    taken = exchange_module.Exchange.answer_at_once
    tasks: list[asyncio.Task[Any]] = []

    def answer_then_cancel(self: Any, data: bytes, now: float) -> bytes | None:
        reply = taken(self, data, now)
        if reply is not None and self.command.CODE == "GW":
            tasks[0].cancel()  # the cancel arrives with the answer
        return reply

    monkeypatch.setattr(exchange_module.Exchange, "answer_at_once", answer_then_cancel)
    with SimServer(VirtualController(SimConfig())) as server:

        async def run() -> tuple[asyncio.CancelledError, int, str]:
            async with AsyncClient(server.url, timeout=TIMEOUT) as client:
                tasks.append(asyncio.create_task(client.write_global_int(5, 77)))
                with pytest.raises(asyncio.CancelledError) as info:
                    await tasks[0]
                state = client._link.state.value
                return info.value, await client.read_global_int(5), state

        error, value, state = asyncio.run(run())
    [note] = _notes(error)
    assert "GW (WriteGlobalInt)" in note and "carried out" in note and "unknown" not in note
    assert value == 77 and state == "IDLE"  # carried out; the link idle, no RST pending


def test_a_state_change_cancelled_in_the_gap_after_a_stale_packet_was_reset_was_not_sent() -> None:
    """In the quiet gap after the client's own abort the link answers a stale packet with RST:
    that write is not the request, so a state change cancelled still in the gap was not sent."""
    from robostar.protocol.frame import encode_packet
    from robostar.protocol.packets import make_answer
    from robostar.transport import AsyncPeerTransport

    from .test_client_hostile_controller import Scripted

    stale = encode_packet(make_answer(0x30, b"%6d" % 1010))
    peer = Scripted(lambda data, n: [(0.5, stale)] if n == 1 else [])

    async def run() -> asyncio.CancelledError:
        client = AsyncClient(AsyncPeerTransport(peer), timeout=TIMEOUT)
        await client.connect()
        await _cancel_after(lambda: client.read_global_int(10), 0.05)  # RST; the gap begins
        peer._queue.append((time.monotonic() + 0.1, stale))  # a stale packet in the gap
        error = await _cancel_after(lambda: client.write_global_int(5, 1), 0.3)
        await client.close()
        return error

    error = asyncio.run(run())
    [note] = _notes(error)
    assert "before its request was sent: not carried out" in note
    assert [data[1:3] for data in peer.requests] == [b"GR"]
