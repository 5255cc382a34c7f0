"""Slots of the asyncio host are held only by connections in use: idle ones are closed after
``idle_timeout``, dead peers are detected by TCP keepalive, and a connection past ``max_clients`` is
told its request was not done (a definite refusal, not a vanished connection)."""

from __future__ import annotations

import asyncio
import math
import socket
import sys

import pytest

from robostar import AsyncClient
from robostar.commands.control import SetSpeed
from robostar.controller_role import ControllerSession
from robostar.controller_role.limits import IDLE_TIMEOUT, MAX_CLIENTS, HostLimits
from robostar.errors import FunctionFailedError, OutcomeUnknownError, UsageError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.n1.host import AsyncHost

from .host_fakes import STATUS, LateStatus


async def _closed(reader: asyncio.StreamReader, within: float) -> bool:
    return await asyncio.wait_for(reader.read(10), within) == b""


def test_idle_connections_are_closed_and_their_slots_served_again(
    caplog: pytest.LogCaptureFixture,
) -> None:
    async def main() -> None:
        backend = LateStatus()
        factory = lambda name: ControllerSession(backend, name=name)  # noqa: E731
        async with AsyncHost(factory, max_clients=2, idle_timeout=0.3) as host:
            address = await host.start()
            idle = [await asyncio.open_connection(*address) for _ in range(2)]
            await asyncio.sleep(0.05)
            assert host.clients == 2
            for reader, _ in idle:
                assert await _closed(reader, 2.0)
            async with AsyncClient(f"tcp://{address[0]}:{address[1]}") as client:
                assert await client.status() == STATUS
            for _, writer in idle:
                writer.close()

    asyncio.run(main())
    assert "nothing sent or received for 0.3 s (idle_timeout)" in caplog.text


def test_a_connection_in_use_is_not_closed_for_idleness() -> None:
    async def main() -> None:
        backend = LateStatus()
        opened: list[str] = []

        def factory(name: str) -> ControllerSession:
            opened.append(name)
            return ControllerSession(backend, name=name)

        async with AsyncHost(factory, idle_timeout=0.3) as host:
            address = await host.start()
            async with AsyncClient(f"tcp://{address[0]}:{address[1]}") as client:
                for _ in range(10):  # 1 s of polling, three idle periods
                    assert await client.status() == STATUS
                    await asyncio.sleep(0.1)
                assert host.clients == 1
        assert len(opened) == 1  # one session all along: never closed and reopened

    asyncio.run(main())


def test_a_connection_past_the_limit_is_told_nothing_was_done() -> None:
    async def main() -> BaseException | None:
        backend = LateStatus()
        factory = lambda name: ControllerSession(backend, name=name)  # noqa: E731
        async with AsyncHost(factory, max_clients=1) as host:
            address = await host.start()
            _, holder = await asyncio.open_connection(*address)
            await asyncio.sleep(0.05)
            try:
                async with AsyncClient(f"tcp://{address[0]}:{address[1]}", timeout=1.0) as late:
                    await late.execute(SetSpeed(1, 20))
                return None
            except Exception as exc:
                return exc
            finally:
                holder.close()
                assert host.clients <= 1

    error = asyncio.run(main())
    assert not isinstance(error, OutcomeUnknownError), error
    assert isinstance(error, FunctionFailedError), repr(error)


def test_a_silent_connection_past_the_limit_is_closed_within_a_second_or_two() -> None:
    async def main() -> None:
        backend = LateStatus()
        factory = lambda name: ControllerSession(backend, name=name)  # noqa: E731
        async with AsyncHost(factory, max_clients=1) as host:
            address = await host.start()
            _, holder = await asyncio.open_connection(*address)
            reader, late = await asyncio.open_connection(*address)
            assert await _closed(reader, 3.0)
            assert not host.turned_away
            for writer in (holder, late):
                writer.close()

    asyncio.run(main())


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="TCP_KEEPIDLE is Linux's")
def test_served_sockets_have_keepalive_with_short_probes() -> None:
    async def main() -> tuple[int, int, int, int]:
        backend = LateStatus()
        async with AsyncHost(lambda name: ControllerSession(backend, name=name)) as host:
            address = await host.start()
            _, writer = await asyncio.open_connection(*address)
            await asyncio.sleep(0.05)
            [connection] = host.connections
            assert connection.transport is not None
            sock = connection.transport.get_extra_info("socket")
            got = (
                sock.getsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE),
                sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPIDLE),
                sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPINTVL),
                sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPCNT),
            )
            writer.close()
            return got

    keepalive, idle, interval, count = asyncio.run(main())
    assert keepalive and idle + interval * count <= 60, (idle, interval, count)


def test_sixteen_idle_n1_connections_no_longer_lock_out_the_host_program() -> None:
    """The review's case, through the line server's N1 face: sixteen connections a leaky
    script left open. The seventeenth is told, definitely, that nothing was done; once the
    idle ones are closed, the host program is served."""

    async def main() -> tuple[BaseException | None, BaseException | None]:
        config = ServeConfig(
            lines=(LineConfig("cell1", "sim://", poll_interval=0.5),),
            faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
        )
        async with LineServer(config) as server:
            face = server.faces["n1"]
            n1 = face.hosts["cell1"]  # type: ignore[attr-defined]
            assert (n1.max_clients, n1.idle_timeout) == (MAX_CLIENTS, IDLE_TIMEOUT)
            n1.idle_timeout = 0.5  # the default is ten minutes; the wiring is the same
            host, port = face.addresses["cell1"]  # type: ignore[attr-defined]
            idle = [await asyncio.open_connection(host, port) for _ in range(16)]
            await asyncio.sleep(0.1)
            results: list[BaseException | None] = []
            for wait in (0.0, 1.0):
                await asyncio.sleep(wait)
                try:
                    async with AsyncClient(f"tcp://{host}:{port}", timeout=1.0) as program:
                        await program.execute(SetSpeed(1, 20))
                    results.append(None)
                except Exception as exc:
                    results.append(exc)
            for _, writer in idle:
                writer.close()
            return results[0], results[1]

    turned_away, later = asyncio.run(main())
    assert isinstance(turned_away, FunctionFailedError), repr(turned_away)
    assert later is None, repr(later)


def test_host_limits_from_a_config_table() -> None:
    assert HostLimits.from_options({}) == HostLimits(MAX_CLIENTS, IDLE_TIMEOUT)
    assert HostLimits.from_options({"max_clients": 64, "idle_timeout": 0}) == HostLimits(64, None)
    for options, key in (
        ({"max_clients": 0}, "n1.max_clients"),
        ({"max_clients": True}, "n1.max_clients"),
        ({"max_clients": 2.5}, "n1.max_clients"),
        ({"idle_timeout": math.nan}, "n1.idle_timeout"),
        ({"idle_timeout": math.inf}, "n1.idle_timeout"),
        ({"idle_timeout": -1}, "n1.idle_timeout"),
        ({"idle_timeout": "10m"}, "n1.idle_timeout"),
    ):
        with pytest.raises(UsageError, match=rf"^{key}: "):
            HostLimits.from_options(options)
    with pytest.raises(UsageError, match="idle_timeout"):
        AsyncHost(lambda name: ControllerSession(LateStatus(), name=name), idle_timeout=0)
