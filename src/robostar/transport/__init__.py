"""Byte pipes by URL (serial, tcp://, sim://, pyserial URLs). Knows nothing of the protocol."""

from robostar.transport.aio import AsyncSerialTransport, AsyncTcpTransport, ThreadedAsyncTransport
from robostar.transport.base import AsyncTransport, Transport
from robostar.transport.inproc import AsyncPeerTransport, PeerTransport
from robostar.transport.opener import (
    async_transport_for_url,
    open_async_transport,
    open_transport,
    transport_for_url,
)
from robostar.transport.peer import BytePeer
from robostar.transport.serial_port import SerialTransport
from robostar.transport.tcp import TcpTransport
from robostar.transport.url import DEFAULT_BAUDRATE, DEFAULT_TCP_PORT

__all__ = [
    "DEFAULT_BAUDRATE",
    "DEFAULT_TCP_PORT",
    "AsyncPeerTransport",
    "AsyncSerialTransport",
    "AsyncTcpTransport",
    "AsyncTransport",
    "BytePeer",
    "PeerTransport",
    "SerialTransport",
    "TcpTransport",
    "ThreadedAsyncTransport",
    "Transport",
    "async_transport_for_url",
    "open_async_transport",
    "open_transport",
    "transport_for_url",
]
