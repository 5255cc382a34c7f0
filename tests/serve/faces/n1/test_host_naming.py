"""Naming a new N1 connection (who holds its socket: a read of ``/proc``) never holds up the
server: the loop serves every other host meanwhile, bytes the new host sends before its name is
known reach its session once it exists (under its final name), and a connection that closes or
goes silent during the lookup, or the host closing, leaves no session behind (and a lookup still
queued for it is not made)."""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from robostar import AsyncClient, Client
from robostar.commands.control import SetSpeed
from robostar.commands.status import ReadStatus
from robostar.errors import FunctionFailedError
from robostar.protocol.frame import FrameDecoder, Packet, encode_packet
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.n1 import peer_owner
from robostar.serve.faces.n1.host import AsyncHost
from robostar.serve.faces.n1.peer_owner import PeerOwner

from .host_fakes import STATUS, LateStatus

pytestmark = pytest.mark.timeout(60)

_ACK = b"\x06"
GIVE_UP = 20.0
"""Seconds a blocked lookup or a test's wait gives up after: only ever reached when the loop is
stalled (the test then fails), never a measure of speed."""


class SlowLookup:
    """A ``find_owner`` that blocks until released, from the lookup thread, and says whether
    the release came (``released``) or it gave up."""

    def __init__(self) -> None:
        self.entered = threading.Event()
        self.release = threading.Event()
        self.released: list[bool] = []
        self.ports: list[int] = []
        """The peers' ports looked up, in order."""

    def __call__(self, host: str, port: int, proc: Path = Path("/proc")) -> PeerOwner | None:
        self.ports.append(port)
        self.entered.set()
        self.released.append(self.release.wait(GIVE_UP))
        return PeerOwner("tester")


@pytest.fixture
def slow_lookup(monkeypatch: pytest.MonkeyPatch) -> Iterator[SlowLookup]:
    peer_owner._lookups.clear()  # this second's lookup budget unspent (other tests connect too)
    lookup = SlowLookup()
    monkeypatch.setattr(peer_owner, "find_owner", lookup)
    yield lookup
    lookup.release.set()  # never leave a worker thread waiting


async def _until(condition: object, what: str) -> None:
    """Wait, turn by turn of the loop, until ``condition()`` holds (GIVE_UP: it never did)."""
    assert callable(condition)
    for _ in range(int(GIVE_UP / 0.005)):
        if condition():
            return
        await asyncio.sleep(0.005)
    raise AssertionError(f"never: {what}")


async def _exchange(
    reader: asyncio.StreamReader, writer: asyncio.StreamWriter, request: bytes | None
) -> bytes:
    """One N1 exchange by hand (``request`` None: it was sent already): the answer, then ACK."""
    if request is not None:
        writer.write(encode_packet(request))
    decoder = FrameDecoder()
    while True:
        data = await asyncio.wait_for(reader.read(256), GIVE_UP)
        assert data, "the connection closed"
        packets = [event for event in decoder.feed(data) if isinstance(event, Packet)]
        if packets:
            writer.write(_ACK)
            return packets[0].data


def _early_bytes(host: AsyncHost) -> int:
    """Bytes held by connections whose name is being looked up (white box: no other view)."""
    return sum(len(getattr(c, "_early", None) or b"") for c in host.connections)


def test_the_server_answers_other_hosts_while_a_new_one_is_named(slow_lookup: SlowLookup) -> None:
    """Passes only when the loop is free during a lookup: the lookup is released by an answer
    that another host gets through the same server."""
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.5),),
        faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
    )

    async def main() -> None:
        async with LineServer(config) as server:
            face = server.faces["n1"]
            address = face.addresses["cell1"]  # type: ignore[attr-defined]
            host = face.hosts["cell1"]  # type: ignore[attr-defined]
            line = server.lines["cell1"]
            slow_lookup.release.set()  # the first host is named at once
            first = Client(f"tcp://{address[0]}:{address[1]}", timeout=GIVE_UP)
            try:
                await asyncio.to_thread(first.status)
                slow_lookup.release.clear()
                slow_lookup.entered.clear()
                # a second host connects and sends AA before the server knows its name
                reader, writer = await asyncio.open_connection(*address)
                writer.write(encode_packet(ReadStatus().encode()))
                assert await asyncio.to_thread(slow_lookup.entered.wait, GIVE_UP)
                await _until(lambda: _early_bytes(host) > 0, "the AA waits for the name")
                # the first host is served meanwhile; its answer releases the lookup
                await asyncio.to_thread(first.status)
                slow_lookup.release.set()
                answer = await _exchange(reader, writer, None)
                assert len(ReadStatus().decode_answer([answer])) == 3
                # the second host's session has its final name: the lease says who writes
                await _exchange(reader, writer, SetSpeed(1, 400).encode())
                holder = line.control().holder
                assert holder is not None and holder.endswith(" (tester)"), holder
                writer.close()
            finally:
                await asyncio.to_thread(first.close)
        assert slow_lookup.released == [True, True]

    asyncio.run(main())


@pytest.mark.parametrize("closed_by", ["the host program", "the server", "idle_timeout"])
def test_a_connection_gone_during_its_lookup_leaves_no_session(
    slow_lookup: SlowLookup, caplog: pytest.LogCaptureFixture, closed_by: str
) -> None:
    caplog.set_level(logging.DEBUG, logger="robostar.serve.faces.n1.host")
    backend = LateStatus()

    async def main() -> None:
        idle = 0.05 if closed_by == "idle_timeout" else None
        host = AsyncHost(backend.session, idle_timeout=idle)
        address = await host.start()
        try:
            _, writer = await asyncio.open_connection(*address)
            writer.write(encode_packet(ReadStatus().encode()))
            assert await asyncio.to_thread(slow_lookup.entered.wait, GIVE_UP)
            assert host.clients == 1  # it holds its slot while it is named
            if closed_by == "the host program":
                writer.close()
            elif closed_by == "the server":
                await host.close()
            await _until(lambda: host.clients == 0, "the connection is gone")
            slow_lookup.release.set()
            await _until(lambda: "left before it was named" in caplog.text, "the lookup ended")
            assert backend.made == []
            writer.close()
        finally:
            await host.close()

    asyncio.run(main())


def test_a_connection_being_named_holds_its_slot(slow_lookup: SlowLookup) -> None:
    backend = LateStatus()

    async def main() -> None:
        async with AsyncHost(backend.session, max_clients=1) as host:
            address = await host.start()
            url = f"tcp://{address[0]}:{address[1]}"
            first = AsyncClient(url, timeout=GIVE_UP)
            first_status = asyncio.ensure_future(first.status())
            try:
                assert await asyncio.to_thread(slow_lookup.entered.wait, GIVE_UP)
                async with AsyncClient(url) as second:
                    with pytest.raises(FunctionFailedError, match="already 1 clients"):
                        await second.status()
                slow_lookup.release.set()
                assert await first_status == STATUS
                assert len(backend.made) == 1
                assert backend.made[0].endswith(" (tester)"), backend.made
            finally:
                await first.close()

    asyncio.run(main())


def test_a_lookup_queued_for_a_connection_gone_is_not_made(slow_lookup: SlowLookup) -> None:
    backend = LateStatus()

    async def main() -> None:
        async with AsyncHost(backend.session) as host:
            address = await host.start()
            first = AsyncClient(f"tcp://{address[0]}:{address[1]}", timeout=GIVE_UP)
            first_status = asyncio.ensure_future(first.status())
            try:
                assert await asyncio.to_thread(slow_lookup.entered.wait, GIVE_UP)
                # the lookup thread is busy with the first: the second's lookup waits its turn
                _, second = await asyncio.open_connection(*address)
                await _until(lambda: host.clients == 2, "the second connection")
                second.close()
                await _until(lambda: host.clients == 1, "the second connection gone")
                slow_lookup.release.set()
                assert await first_status == STATUS
                # a third connection is looked up after the first, the second never was
                async with AsyncClient(f"tcp://{address[0]}:{address[1]}") as third:
                    assert await third.status() == STATUS
                assert len(slow_lookup.ports) == 2
                assert len(backend.made) == 2
            finally:
                await first.close()

    asyncio.run(main())
