"""The asyncio host with a tiny backend that answers AA later, as a line server would."""

from __future__ import annotations

import asyncio

import pytest

from robostar import AsyncClient
from robostar.controller_role import ControllerSession, Request
from robostar.errors import FunctionFailedError, NotSupportedError
from robostar.protocol.frame import encode_packet
from robostar.serve.faces.n1.host import AsyncHost

from .host_fakes import STATUS, LateStatus


def test_a_late_answer_reaches_each_of_many_clients() -> None:
    asyncio.run(_many_clients())


async def _many_clients() -> None:
    backend = LateStatus()
    async with AsyncHost(lambda name: ControllerSession(backend, name=name), max_clients=4) as host:
        address = await host.start()
        url = f"tcp://{address[0]}:{address[1]}"
        clients = [AsyncClient(url) for _ in range(3)]
        try:
            results = await asyncio.gather(*(c.status() for c in clients for _ in range(5)))
            assert all(result == STATUS for result in results)
            assert host.clients == 3
        finally:
            for client in clients:
                await client.close()
    assert len(backend.closed) == 3


def test_a_refusal_answers_its_flag_and_kd_reason() -> None:
    asyncio.run(_refusal())


async def _refusal() -> None:
    backend = LateStatus()
    sessions: list[ControllerSession] = []

    def factory(name: str) -> ControllerSession:
        sessions.append(ControllerSession(backend, name=name))
        return sessions[-1]

    async with AsyncHost(factory) as host:
        address = await host.start()
        async with AsyncClient(f"tcp://{address[0]}:{address[1]}") as client:
            with pytest.raises((NotSupportedError, FunctionFailedError)):
                await client.reset_alarms()
            assert await client.status() == STATUS
    assert "is not served here" in sessions[0].last_error


def test_connections_past_the_limit_are_refused_and_logged(
    caplog: pytest.LogCaptureFixture,
) -> None:
    asyncio.run(_past_the_limit())
    assert "already 1 clients" in caplog.text


async def _past_the_limit() -> None:
    backend = LateStatus()
    async with AsyncHost(lambda name: ControllerSession(backend, name=name), max_clients=1) as host:
        address = await host.start()
        _, first = await asyncio.open_connection(*address)
        reader, second = await asyncio.open_connection(*address)
        assert await asyncio.wait_for(reader.read(10), 2.0) == b""
        assert host.clients == 1
        for writer in (first, second):
            writer.close()


class BuggyStatus(LateStatus):
    def handle(self, request: Request) -> None:
        if request.command.CODE == "KD":
            raise RuntimeError("bug")
        super().handle(request)


def test_a_failing_session_is_dropped_alone(caplog: pytest.LogCaptureFixture) -> None:
    asyncio.run(_failing_session())
    assert "failed; dropped" in caplog.text


async def _failing_session() -> None:
    backend = BuggyStatus()
    async with AsyncHost(lambda name: ControllerSession(backend, name=name)) as host:
        address = await host.start()
        async with AsyncClient(f"tcp://{address[0]}:{address[1]}") as good:
            reader, writer = await asyncio.open_connection(*address)
            writer.write(encode_packet(b"\xffKD"))
            assert await asyncio.wait_for(reader.read(100), 2.0) == b""
            writer.close()
            assert await good.status() == STATUS
            assert host.clients == 1
