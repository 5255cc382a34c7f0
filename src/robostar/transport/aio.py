"""asyncio transports: TCP and serial devices through asyncio protocols, others in a thread."""

from __future__ import annotations

import asyncio
import contextlib
import socket
import time
from abc import abstractmethod
from collections.abc import Awaitable
from typing import Any, cast

import serial
import serial_asyncio_fast

from robostar.errors import PortError
from robostar.transport.base import Answerer, AsyncTransport, Transport
from robostar.transport.serial_port import SerialSettings, port_error
from robostar.transport.tcp import tcp_open_error
from robostar.transport.url import DEFAULT_BAUDRATE, DEFAULT_TCP_PORT

__all__ = ["AsyncSerialTransport", "AsyncTcpTransport", "ReaderProtocol", "ThreadedAsyncTransport"]


class ReaderProtocol(asyncio.Protocol):
    """Collects what the line delivers and wakes the one reader waiting for it.

    An asyncio.Protocol rather than streams: a read of bytes already here is a buffer swap, and
    a read that waits is one future and one timer, with no stream machinery per exchange.
    """

    def __init__(self) -> None:
        self.buffer = bytearray()
        self.waiter: asyncio.Future[None] | None = None
        self.deadline = 0.0  # the waiter's, in the loop's time
        self.lost = False
        self.lost_reason: BaseException | None = None
        self.paused = False
        self.drained: asyncio.Future[None] | None = None
        self._timer: asyncio.TimerHandle | None = None
        self._timer_at = 0.0
        self.answer: Answerer | None = None
        """Offered what arrives while a read waits (:meth:`AsyncTransport.read_answering`)."""
        self.answer_failed: BaseException | None = None
        """Writing what :attr:`answer` returned failed: the read reports the line lost."""
        self._line: asyncio.WriteTransport | None = None

    def wait_until(self, loop: asyncio.AbstractEventLoop, deadline: float) -> asyncio.Future[None]:
        """A new waiter, woken by data, a lost line or ``deadline`` (loop time).

        One timer serves every read: it stays armed from one read to the next and, when it
        fires before the current waiter's deadline, sets itself again for it. A read a few
        microseconds after the last one (the usual case: a reply timeout of seconds) then
        schedules and cancels no timer of its own.
        """
        waiter = self.waiter = loop.create_future()
        self.deadline = deadline
        timer = self._timer
        if timer is None or self._timer_at > deadline:
            if timer is not None:
                timer.cancel()
            self._timer_at = deadline
            self._timer = loop.call_at(deadline, self._time_up, loop)
        return waiter

    def _time_up(self, loop: asyncio.AbstractEventLoop) -> None:
        self._timer = None
        waiter = self.waiter
        if waiter is None or waiter.done():
            return
        if self.deadline <= self._timer_at:
            waiter.set_result(None)
        else:  # a later read's deadline: wait on for it
            self._timer_at = self.deadline
            self._timer = loop.call_at(self.deadline, self._time_up, loop)

    def disarm(self) -> None:
        """Cancel the timer (the line is closing)."""
        timer, self._timer = self._timer, None
        if timer is not None:
            timer.cancel()

    def _wake(self) -> None:
        waiter = self.waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self._line = cast(asyncio.WriteTransport, transport)

    def data_received(self, data: bytes) -> None:
        answer = self.answer
        if answer is not None and not self.buffer:
            reply = answer(data, time.monotonic())
            if reply is not None:
                self.answer = None  # one answer per read
                if reply:
                    try:
                        assert self._line is not None
                        self._line.write(reply)
                    except (OSError, serial.SerialException) as exc:
                        self.answer_failed = exc
                self._wake()
                return
        self.buffer += data
        self._wake()

    def eof_received(self) -> bool:
        return False  # close the transport: the peer is gone

    def connection_lost(self, exc: Exception | None) -> None:
        self.lost = True
        self.lost_reason = exc
        self._wake()
        self.resume_writing()

    def pause_writing(self) -> None:
        self.paused = True

    def resume_writing(self) -> None:
        self.paused = False
        drained, self.drained = self.drained, None
        if drained is not None and not drained.done():
            drained.set_result(None)


class _ProtocolTransport(AsyncTransport):
    """A line driven through :class:`ReaderProtocol`; subclasses say how to connect."""

    _own_write = True
    _own_read = True
    """The class's write/read are these (the nowait twins do their usual case themselves);
    a subclass that changes them is left its own."""

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        cls._own_write = cls.write is _ProtocolTransport.write
        cls._own_read = cls.read is _ProtocolTransport.read

    def __init__(self) -> None:
        self._transport: asyncio.BaseTransport | None = None
        self._protocol: ReaderProtocol | None = None

    @property
    def is_open(self) -> bool:
        return self._transport is not None

    @abstractmethod
    async def _connect(self) -> tuple[asyncio.BaseTransport, ReaderProtocol]:
        """Open the line and return its transport and protocol, or raise PortError."""

    async def open(self) -> None:
        if self._transport is None:
            self._transport, self._protocol = await self._connect()

    async def close(self) -> None:
        transport, self._transport = self._transport, None
        protocol, self._protocol = self._protocol, None
        if protocol is not None:
            protocol.disarm()
        if transport is not None:
            transport.close()
            # Let the transport finish closing (its connection_lost runs on the next turns).
            await asyncio.sleep(0)

    async def _lost(self, exc: BaseException | None) -> PortError:
        await self.close()
        detail = f" ({exc})" if exc else ""
        return PortError(f"{self.url}: the connection was lost{detail}")

    async def write(self, data: bytes) -> None:
        transport, protocol = self._transport, self._protocol
        if transport is None or protocol is None:
            raise self._closed_error()
        if protocol.lost:
            raise await self._lost(protocol.lost_reason)
        try:
            transport.write(data)  # type: ignore[attr-defined]
        except (OSError, serial.SerialException) as exc:
            raise await self._lost(exc) from exc
        if protocol.paused:
            await self._drain_written(protocol)

    def write_nowait(self, data: bytes) -> Awaitable[None] | None:
        # write()'s usual case without its coroutine: an open line taking the bytes into a
        # write buffer below its high-water mark. Anything else is write() itself (nothing
        # written yet) or its tail (written: wait for the buffer to drain, or report the loss).
        transport, protocol = self._transport, self._protocol
        if not self._own_write or transport is None or protocol is None or protocol.lost:
            return self.write(data)
        try:
            transport.write(data)  # type: ignore[attr-defined]
        except (OSError, serial.SerialException) as exc:
            return self._write_failed(exc)
        if protocol.paused:
            return self._drain_written(protocol)
        return None

    async def _write_failed(self, exc: BaseException) -> None:
        raise await self._lost(exc) from exc

    async def _drain_written(self, protocol: ReaderProtocol) -> None:
        drained = protocol.drained
        if drained is None:
            drained = protocol.drained = asyncio.get_running_loop().create_future()
        await drained
        if protocol.lost:
            raise await self._lost(protocol.lost_reason)

    def read_nowait(self) -> bytes | None:
        protocol = self._protocol
        if not self._own_read or protocol is None or protocol.lost:
            return None  # read() says what is wrong
        if protocol.buffer:
            data = bytes(protocol.buffer)
            protocol.buffer.clear()
            return data
        return b""

    async def read_answering(self, timeout: float, answer: Answerer) -> bytes:
        protocol = self._protocol
        if (
            not self._own_read
            or protocol is None
            or protocol.buffer
            or protocol.lost
            or timeout <= 0
        ):
            return await self.read(timeout)  # nothing to offer, or read() says what is wrong
        # read()'s wait, with the answerer in place while it lasts
        loop = asyncio.get_running_loop()
        protocol.answer = answer
        try:
            await protocol.wait_until(loop, loop.time() + timeout)
            taken = protocol.answer is None  # data_received gave it its answer
        finally:
            protocol.waiter = None
            protocol.answer = None
        failed = protocol.answer_failed
        if failed is not None:
            protocol.answer_failed = None
            raise await self._lost(failed) from failed
        if taken:
            # Bytes behind the answer (a loop that reads twice a turn) stay for the next read.
            return b""
        return await self._what_came(protocol)

    async def read(self, timeout: float) -> bytes:
        protocol = self._protocol
        if protocol is None:
            raise self._closed_error()
        if not protocol.buffer and not protocol.lost and timeout > 0:
            loop = asyncio.get_running_loop()
            try:
                await protocol.wait_until(loop, loop.time() + timeout)
            finally:
                protocol.waiter = None
        return await self._what_came(protocol)

    async def _what_came(self, protocol: ReaderProtocol) -> bytes:
        """After a wait: the bytes that came, else the line's loss, else nothing."""
        if protocol.buffer:
            data = bytes(protocol.buffer)
            protocol.buffer.clear()
            return data
        if protocol.lost:
            raise await self._lost(protocol.lost_reason)
        return b""


class AsyncTcpTransport(_ProtocolTransport):
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

    async def _connect(self) -> tuple[asyncio.BaseTransport, ReaderProtocol]:
        loop = asyncio.get_running_loop()
        try:
            async with asyncio.timeout(self.connect_timeout):
                transport, protocol = await loop.create_connection(
                    ReaderProtocol, self.host, self.port
                )
        except OSError as exc:
            raise tcp_open_error(self.url, exc) from exc
        # asyncio sets TCP_NODELAY on its own TCP transports; say it anyway (older loops).
        sock = transport.get_extra_info("socket")
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return transport, protocol


class AsyncSerialTransport(_ProtocolTransport):
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

    async def _connect(self) -> tuple[asyncio.BaseTransport, ReaderProtocol]:
        settings = self.settings.as_kwargs()
        if not self.is_url:
            settings["exclusive"] = self.exclusive or None
        loop = asyncio.get_running_loop()
        try:
            transport, protocol = await serial_asyncio_fast.create_serial_connection(
                loop, ReaderProtocol, self.port, **settings
            )
        except (serial.SerialException, OSError) as exc:
            raise port_error(self.port, exc) from exc
        except ValueError as exc:
            raise PortError(f"{self.port}: bad serial settings: {exc}") from exc
        assert isinstance(protocol, ReaderProtocol)
        if self.low_latency:
            port: Any = transport.get_extra_info("serial")
            # A pty or an adapter without the mode: nothing to gain, nothing lost.
            with contextlib.suppress(AttributeError, NotImplementedError, OSError, ValueError):
                port.set_low_latency_mode(True)
        return transport, protocol


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
