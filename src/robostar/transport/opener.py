"""Transports by URL: :func:`open_transport` and :func:`open_async_transport`.

``sim://`` imports :mod:`robostar.sim` only when asked for, so that the transport layer keeps
knowing nothing of the protocol (the simulator is built on it).
"""

from __future__ import annotations

from typing import Any

from robostar.transport.aio import AsyncSerialTransport, AsyncTcpTransport, ThreadedAsyncTransport
from robostar.transport.base import AsyncTransport, Transport
from robostar.transport.inproc import AsyncPeerTransport, PeerTransport
from robostar.transport.line_server import AsyncServeTransport, ServeTransport
from robostar.transport.peer import BytePeer
from robostar.transport.serial_port import SerialTransport
from robostar.transport.tcp import TcpTransport
from robostar.transport.url import (
    SERIAL_OPTIONS,
    SERVE_OPTIONS,
    TCP_OPTIONS,
    Endpoint,
    Kind,
    coerce_options,
    parse_url,
)

__all__ = [
    "async_transport_for_url",
    "open_async_transport",
    "open_transport",
    "transport_for_url",
]

# pyserial URL handlers that asyncio can wait on directly (they have a socket).
_ASYNC_STREAM_SCHEMES = ("socket://",)


def _sim_peer(endpoint: Endpoint) -> BytePeer:
    from robostar.sim import SimConfig, VirtualController

    query = {name: str(value) for name, value in endpoint.options.items()}
    return VirtualController(SimConfig.from_query(query))


def _serve_options(endpoint: Endpoint) -> tuple[str, dict[str, Any]]:
    options = dict(endpoint.options)
    line = str(options.pop("line"))
    return line, coerce_options(endpoint.url, options, SERVE_OPTIONS)


def transport_for_url(url: str, **options: Any) -> Transport:
    """A closed :class:`Transport` for ``url``; ``options`` override the URL's query.

    Serial options: ``baudrate`` (115200), ``bytesize`` (8), ``parity`` ("N"), ``stopbits``
    (1), ``rtscts``/``xonxoff``/``dsrdtr`` (off), ``exclusive`` (on), ``low_latency`` (on).
    TCP: ``connect_timeout`` (5 s). ``sim://``: the simulator's own options.
    """
    endpoint = parse_url(url, options)
    if endpoint.kind is Kind.SIM:
        return PeerTransport(_sim_peer(endpoint), url=url)
    if endpoint.kind is Kind.SERVE:
        line, serve = _serve_options(endpoint)
        return ServeTransport(endpoint.target, endpoint.port, line, url=url, **serve)
    if endpoint.kind is Kind.TCP:
        tcp = coerce_options(url, endpoint.options, TCP_OPTIONS)
        return TcpTransport(endpoint.target, endpoint.port, url=url, **tcp)
    settings = coerce_options(url, endpoint.options, SERIAL_OPTIONS)
    return SerialTransport(
        endpoint.target,
        is_url=endpoint.kind is Kind.PYSERIAL_URL,
        **settings,
    )


def async_transport_for_url(url: str, **options: Any) -> AsyncTransport:
    """A closed :class:`AsyncTransport` for ``url``; the options of :func:`transport_for_url`."""
    endpoint = parse_url(url, options)
    if endpoint.kind is Kind.SIM:
        return AsyncPeerTransport(_sim_peer(endpoint), url=url)
    if endpoint.kind is Kind.SERVE:
        line, serve = _serve_options(endpoint)
        return AsyncServeTransport(endpoint.target, endpoint.port, line, url=url, **serve)
    if endpoint.kind is Kind.TCP:
        tcp = coerce_options(url, endpoint.options, TCP_OPTIONS)
        return AsyncTcpTransport(endpoint.target, endpoint.port, url=url, **tcp)
    settings = coerce_options(url, endpoint.options, SERIAL_OPTIONS)
    if endpoint.kind is Kind.SERIAL or url.lower().startswith(_ASYNC_STREAM_SCHEMES):
        return AsyncSerialTransport(endpoint.target, **settings)
    return ThreadedAsyncTransport(SerialTransport(endpoint.target, is_url=True, **settings))


def open_transport(url: str, **options: Any) -> Transport:
    """Open a transport by URL (see :func:`transport_for_url`); PortError if it cannot."""
    transport = transport_for_url(url, **options)
    transport.open()
    return transport


async def open_async_transport(url: str, **options: Any) -> AsyncTransport:
    """Open an asyncio transport by URL; PortError if it cannot."""
    transport = async_transport_for_url(url, **options)
    await transport.open()
    return transport
