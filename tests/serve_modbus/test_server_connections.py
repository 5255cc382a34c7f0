"""The Modbus face's connections are bounded: past ``max_clients`` a new one is closed at once
and the PLCs already connected are served on; a connection silent for ``idle_timeout`` is
closed (a PLC that lost power leaves a half-open one), and its place is free again; a scan
for the device's identification names the server and its map."""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path

import pytest
from pymodbus.client import AsyncModbusTcpClient
from pymodbus.exceptions import ModbusException

from robostar import __version__
from robostar.errors import UsageError
from robostar.listen import admits
from robostar.serve.faces.modbus.layout import IR, MAP_VERSION
from robostar.serve.faces.modbus.server import RegisterServer
from robostar.serve.faces.modbus.settings import settings_from

from .conftest import Cell, cell, until


def _server(c: Cell) -> RegisterServer:
    return c.server.faces["modbus"].servers["cell1"]  # type: ignore[attr-defined,no-any-return]


async def _plc(c: Cell) -> AsyncModbusTcpClient:
    host, port = c.server.faces["modbus"].addresses["cell1"]  # type: ignore[attr-defined]
    plc = AsyncModbusTcpClient(host, port=port, timeout=1, retries=0, reconnect_delay=0)
    await plc.connect()
    return plc


async def _answers(plc: AsyncModbusTcpClient) -> bool:
    try:
        answer = await plc.read_input_registers(IR.MAP_VERSION, count=1)
    except ModbusException:
        return False
    return not answer.isError()


def test_a_connection_past_max_clients_is_turned_away(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, max_clients=2) as c:  # c.plc is the first
            second = await _plc(c)
            assert await _answers(second)
            await until(lambda: _server(c).connections == 2)
            third = await _plc(c)
            assert not await _answers(third)
            assert await _answers(second) and await _answers(c.plc)
            third.close()
            second.close()
            await until(lambda: _server(c).connections == 1)
            fourth = await _plc(c)  # a place is free again
            assert await _answers(fourth)
            fourth.close()

    asyncio.run(main())


def test_connections_turned_away_are_logged_once_not_each_time(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A PLC's client that tries again every few milliseconds must not flood the log."""

    async def main() -> None:
        async with cell(tmp_path, max_clients=1) as c:
            for _ in range(5):
                extra = await _plc(c)
                assert not await _answers(extra)
                extra.close()
            assert await _answers(c.plc)

    with caplog.at_level(logging.WARNING, logger="robostar.serve.modbus"):
        asyncio.run(main())
    warnings = [r for r in caplog.records if "turned away" in r.getMessage()]
    assert len(warnings) == 1, [r.getMessage() for r in warnings]


def test_a_silent_connection_is_closed_after_idle_timeout(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, max_clients=1, idle_timeout=1.5) as c:
            assert await _answers(c.plc)
            await until(lambda: _server(c).connections == 0)
            newcomer = await _plc(c)  # the silent one's place
            assert await _answers(newcomer)
            for _ in range(40):  # a PLC that polls keeps its connection past the timeout
                await asyncio.sleep(0.05)
                assert await _answers(newcomer)
            assert _server(c).connections == 1
            newcomer.close()

    asyncio.run(main())


@pytest.mark.parametrize(
    ("key", "value"),
    [("max_clients", 0), ("max_clients", 2.5), ("idle_timeout", -1), ("idle_timeout", "x")],
)
def test_the_connection_settings_are_checked(key: str, value: object) -> None:
    options = {"lines": {"cell1": "127.0.0.1:5020"}, key: value}
    with pytest.raises(UsageError, match=f"modbus.{key}"):
        settings_from(options, {"cell1"})
    settings = settings_from({"lines": {"cell1": "127.0.0.1:5020"}}, {"cell1"})
    assert (settings.max_clients, settings.idle_timeout) == (16, 120.0)


def test_a_scan_names_the_server_and_its_map(tmp_path: Path) -> None:
    """Read Device Identification (43/14), as a commissioning tool's scan sends it."""

    async def main() -> None:
        async with cell(tmp_path) as c:
            answer = await c.plc.read_device_information()
            assert not answer.isError(), answer
            info = answer.information
            assert info[0] == b"robostar"
            assert info[2] == __version__.encode()
            regular = (await c.plc.read_device_information(read_code=2)).information
            assert regular[5] == f"register map version {MAP_VERSION}".encode()

    asyncio.run(main())


def test_beyond_loopback_the_plcs_are_named() -> None:
    """Modbus TCP has no authentication: a listener beyond loopback serves the peers that
    allow_from names (and loopback), no one else."""
    remote = {"lines": {"cell1": "192.0.2.1:502"}, "allow_remote": True}
    with pytest.raises(UsageError, match="allow_from"):
        settings_from(remote, {"cell1"})
    with pytest.raises(UsageError, match=r"modbus\.allow_from"):
        settings_from({**remote, "allow_from": ["plc-7"]}, {"cell1"})
    with pytest.raises(UsageError, match=r"modbus\.allow_from"):
        settings_from({**remote, "allow_from": "192.0.2.7"}, {"cell1"})
    settings = settings_from({**remote, "allow_from": ["192.0.2.7", "10.1.0.0/16"]}, {"cell1"})
    allowed = settings.allow_from
    assert admits(allowed, ("192.0.2.7", 50000))
    assert admits(allowed, ("10.1.200.3", 50000))
    assert admits(allowed, ("::ffff:192.0.2.7", 50000, 0, 0))
    assert admits(allowed, ("127.0.0.1", 50000)) and admits(allowed, ("::1", 50000, 0, 0))
    assert not admits(allowed, ("192.0.2.8", 50000))
    assert not admits(allowed, None)
    assert admits(None, ("192.0.2.8", 50000))  # a loopback listener: whoever reaches it
