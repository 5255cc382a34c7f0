"""The byte-pipe interfaces: a blocking :class:`Transport` and an asyncio :class:`AsyncTransport`.

A transport moves bytes and nothing else: no framing, no protocol. ``read(timeout)`` returns the
bytes that arrived (at least one) or ``b""`` when ``timeout`` seconds passed without any; a
closed or broken line raises :class:`~robostar.errors.PortError`. A closed transport can be
opened again, which is how a client reconnects.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Awaitable, Callable
from types import TracebackType
from typing import Self, TypeAlias

from robostar.errors import PortError

__all__ = ["Answerer", "AsyncTransport", "Transport"]

Answerer: TypeAlias = Callable[[bytes, float], bytes | None]
"""``answer(data, now)``: takes bytes the moment they arrive and returns what to write back at
once, or None to leave them to the read (:meth:`AsyncTransport.read_answering`)."""


class Transport(ABC):
    """A blocking byte pipe. Use it as a context manager or call :meth:`open`/:meth:`close`."""

    url: str = ""
    """Where the pipe goes, for messages (a device path, ``tcp://host:port``, ``sim://``)."""

    @property
    @abstractmethod
    def is_open(self) -> bool:
        """True between a successful :meth:`open` and :meth:`close` (or a broken line)."""

    @abstractmethod
    def open(self) -> None:
        """Open the pipe; PortError saying what is wrong and what to do if it cannot."""

    @abstractmethod
    def close(self) -> None:
        """Close the pipe; closing a closed pipe does nothing."""

    @abstractmethod
    def write(self, data: bytes) -> None:
        """Send ``data`` whole."""

    @abstractmethod
    def read(self, timeout: float) -> bytes:
        """Bytes that arrived within ``timeout`` seconds (``0``: only those already here)."""

    def _closed_error(self) -> PortError:
        return PortError(f"{self.url}: the port is not open")

    def __enter__(self) -> Self:
        if not self.is_open:
            self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "open" if self.is_open else "closed"
        return f"<{type(self).__name__} {self.url} {state}>"


class AsyncTransport(ABC):
    """The asyncio twin of :class:`Transport`."""

    url: str = ""

    @property
    @abstractmethod
    def is_open(self) -> bool:
        """True between a successful :meth:`open` and :meth:`close` (or a broken line)."""

    @abstractmethod
    async def open(self) -> None:
        """Open the pipe; PortError saying what is wrong and what to do if it cannot."""

    @abstractmethod
    async def close(self) -> None:
        """Close the pipe; closing a closed pipe does nothing."""

    @abstractmethod
    async def write(self, data: bytes) -> None:
        """Send ``data`` whole."""

    @abstractmethod
    async def read(self, timeout: float) -> bytes:
        """Bytes that arrived within ``timeout`` seconds (``0``: only those already here)."""

    def write_nowait(self, data: bytes) -> Awaitable[None] | None:
        """Start :meth:`write`: None when ``data`` is written whole with nothing to await,
        else an awaitable that does the rest (or all) of the write; await it. (By default,
        :meth:`write` itself: a transport that can hand bytes over without waiting saves a
        coroutine per write.)"""
        return self.write(data)

    def read_nowait(self) -> bytes | None:
        """``read(0)`` when it needs no awaiting: the bytes already here (empty if none); None
        when the caller must await ``read(0)`` instead (the default)."""
        return None

    async def read_answering(self, timeout: float, answer: Answerer) -> bytes:
        """:meth:`read`, offering what arrives while it waits to ``answer`` first.

        ``answer(data, now)`` runs where the bytes land (on the loop, in the transport's own
        callback), before the waiting task is resumed: when it takes them it returns the bytes
        to write back at once (an ACK), written there and then, and the read returns ``b""``;
        when it returns None the bytes are the read's, as usual. A host then ACKs an answer one
        turn of the loop sooner, while its task is still on its way back, so the controller
        deals with the ACK in that time and not after. ``now`` is ``time.monotonic()``.

        By default nothing is offered: this is :meth:`read`.
        """
        return await self.read(timeout)

    def _closed_error(self) -> PortError:
        return PortError(f"{self.url}: the port is not open")

    async def __aenter__(self) -> Self:
        if not self.is_open:
            await self.open()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    def __repr__(self) -> str:
        state = "open" if self.is_open else "closed"
        return f"<{type(self).__name__} {self.url} {state}>"
