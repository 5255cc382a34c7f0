"""The reference stack: pymodbus's TCP clients against pymodbus's own TCP server.

The exchange is "read 10 holding registers" (function 3): a 12-byte request and a 29-byte
answer, the closest Modbus match to a status poll. ``python -m bench.modbus_ref`` runs the
asyncio server on a free loopback port and prints ``host:port`` once it accepts connections.
"""

from __future__ import annotations

import asyncio
import logging
import socket
import time

from pymodbus.client import AsyncModbusTcpClient, ModbusTcpClient
from pymodbus.datastore import (
    ModbusDeviceContext,
    ModbusSequentialDataBlock,
    ModbusServerContext,
)
from pymodbus.server import ModbusTcpServer

__all__ = ["REGISTERS", "async_loop", "serve", "sync_loop"]

REGISTERS = 10


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


async def _serve() -> None:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    block = ModbusSequentialDataBlock(1, list(range(100)))
    context = ModbusServerContext(devices=ModbusDeviceContext(hr=block), single=True)
    port = _free_port()
    server = ModbusTcpServer(context, address=("127.0.0.1", port))
    task = asyncio.create_task(server.serve_forever())
    for _ in range(500):
        try:
            _, writer = await asyncio.open_connection("127.0.0.1", port)
        except OSError:
            await asyncio.sleep(0.01)
            continue
        writer.close()
        break
    print(f"127.0.0.1:{port}", flush=True)
    await task


def serve() -> None:
    asyncio.run(_serve())


def _split(address: str) -> tuple[str, int]:
    host, port = address.rsplit(":", 1)
    return host, int(port)


def sync_client(address: str) -> ModbusTcpClient:
    host, port = _split(address)
    client = ModbusTcpClient(host, port=port)
    if not client.connect():
        raise ConnectionError(f"pymodbus: cannot connect to {address}")
    return client


def sync_loop(client: ModbusTcpClient, *, seconds: float, limit: int) -> int:
    end = time.perf_counter() + seconds
    done = 0
    while done < limit:
        reply = client.read_holding_registers(0, count=REGISTERS)
        if reply.isError():
            raise RuntimeError(f"pymodbus: {reply}")
        done += 1
        if not done & 63 and time.perf_counter() >= end:
            break
    return done


async def async_client(address: str) -> AsyncModbusTcpClient:
    host, port = _split(address)
    client = AsyncModbusTcpClient(host, port=port)
    if not await client.connect():
        raise ConnectionError(f"pymodbus: cannot connect to {address}")
    return client


async def async_loop(client: AsyncModbusTcpClient, *, seconds: float, limit: int) -> int:
    end = time.perf_counter() + seconds
    done = 0
    while done < limit:
        reply = await client.read_holding_registers(0, count=REGISTERS)
        if reply.isError():
            raise RuntimeError(f"pymodbus: {reply}")
        done += 1
        if not done & 63 and time.perf_counter() >= end:
            break
    return done


if __name__ == "__main__":
    serve()
