"""asyncio transports: TCP and serial devices as streams, anything else through a thread."""

from __future__ import annotations

import asyncio
import contextlib
import socket
from abc import abstractmethod

import serial
import serial_asyncio_fast

from robostar.errors import PortError
from robostar.transport.base import AsyncTransport, Transport
from robostar.transport.serial_port import SerialSettings, port_error
from robostar.transport.tcp import tcp_open_error
from robostar.transport.url import DEFAULT_BAUDRATE, DEFAULT_TCP_PORT

__all__ = ["AsyncSerialTransport", "AsyncTcpTransport", "ThreadedAsyncTransport"]

_READ_SIZE = 4096


class _StreamTransport(AsyncTransport):
    """An asyncio stream pair; subclasses say how to connect."""

    def __init__(self) -> None:
        self._reader: asyncio.StreamReader | None = None
        self._writer: asyncio.StreamWriter | None = None

    @property
    def is_open(self) -> bool:
        return self._writer is not None

    @abstractmethod
    async def _connect(self) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
        """Open the line and return its stream pair, or raise PortError."""

    async def open(self) -> None:
        if self._writer is None:
            self._reader, self._writer = await self._connect()

    async def close(self) -> None:
        writer, self._writer, self._reader = self._writer, None, None
        if writer is not None:
            writer.close()
            with contextlib.suppress(OSError, serial.SerialException):
                await writer.wait_closed()

    async def _lost(self, exc: BaseException | None) -> PortError:
        await self.close()
        detail = f" ({exc})" if exc else ""
        return PortError(f"{self.url}: the connection was lost{detail}")

    async def write(self, data: bytes) -> None:
        writer = self._writer
        if writer is None:
            raise self._closed_error()
        try:
            writer.write(data)
            await writer.drain()
        except (OSError, serial.SerialException) as exc:
            raise await self._lost(exc) from exc

    async def read(self, timeout: float) -> bytes:
        reader = self._reader
        if reader is None:
            raise self._closed_error()
        try:
            # asyncio.timeout (not wait_for) lets a read of already-buffered bytes finish even
            # with a zero timeout.
            async with asyncio.timeout(max(timeout, 0.0)):
                data = await reader.read(_READ_SIZE)
        except TimeoutError:
            return b""
        except (OSError, serial.SerialException) as exc:
            raise await self._lost(exc) from exc
        if not data:
            raise await self._lost(None)
        return data


class AsyncTcpTransport(_StreamTransport):
    """``tcp://host:port`` for asyncio, Nagle off."""

    def __init__(
        self,
        host: str,
        port: int = DEFAULT_TCP_PORT,
        *,
        connect_timeout: float = 5.0,
        url: str = "",
    ) -> None:
        super().__init__()
        self.host = host
        self.port = port
        self.connect_timeout = connect_timeout
        self.url = url or f"tcp://{host}:{port}"

    async def _connect(self) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
        try:
            async with asyncio.timeout(self.connect_timeout):
                reader, writer = await asyncio.open_connection(self.host, self.port)
        except OSError as exc:
            raise tcp_open_error(self.url, exc) from exc
        sock = writer.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return reader, writer


class AsyncSerialTransport(_StreamTransport):
    """A serial device (or ``socket://``) for asyncio, through pyserial-asyncio-fast."""

    def __init__(
        self,
        port: str,
        *,
        baudrate: int = DEFAULT_BAUDRATE,
        bytesize: int = 8,
        parity: str = "N",
        stopbits: float = 1,
        rtscts: bool = False,
        xonxoff: bool = False,
        dsrdtr: bool = False,
        exclusive: bool = True,
        low_latency: bool = True,
    ) -> None:
        super().__init__()
        self.url = port
        self.port = port
        self.settings = SerialSettings(
            baudrate, bytesize, parity, stopbits, rtscts, xonxoff, dsrdtr
        )
        self.is_url = "://" in port
        self.exclusive = exclusive
        self.low_latency = low_latency and not self.is_url

    async def _connect(self) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
        settings = self.settings.as_kwargs()
        if not self.is_url:
            settings["exclusive"] = self.exclusive or None
        try:
            reader, writer = await serial_asyncio_fast.open_serial_connection(
                url=self.port, **settings
            )
        except (serial.SerialException, OSError) as exc:
            raise port_error(self.port, exc) from exc
        except ValueError as exc:
            raise PortError(f"{self.port}: bad serial settings: {exc}") from exc
        if self.low_latency:
            port = writer.transport.get_extra_info("serial")
            # A pty or an adapter without the mode: nothing to gain, nothing lost.
            with contextlib.suppress(AttributeError, NotImplementedError, OSError, ValueError):
                port.set_low_latency_mode(True)
        return reader, writer


class ThreadedAsyncTransport(AsyncTransport):
    """Any blocking :class:`Transport` for asyncio, each call in a worker thread.

    For the pyserial URL handlers that have no file descriptor to wait on (``loop://``,
    ``rfc2217://``). A read cancelled by its task runs on to its timeout in the thread.
    """

    def __init__(self, transport: Transport) -> None:
        self.transport = transport
        self.url = transport.url

    @property
    def is_open(self) -> bool:
        return self.transport.is_open

    async def open(self) -> None:
        await asyncio.to_thread(self.transport.open)

    async def close(self) -> None:
        await asyncio.to_thread(self.transport.close)

    async def write(self, data: bytes) -> None:
        await asyncio.to_thread(self.transport.write, data)

    async def read(self, timeout: float) -> bytes:
        return await asyncio.to_thread(self.transport.read, timeout)
