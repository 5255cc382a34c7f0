"""Listening addresses: loopback unless asked, port ranges, ``HOST:PORT`` text, remote warnings,
and the peers a listener serves (``allow_from``, for faces whose protocol has no authentication)."""

from __future__ import annotations

import ipaddress
import logging
import socket
import sys
from collections.abc import Iterable, Mapping

from robostar.errors import UsageError

__all__ = [
    "DEFAULT_LISTEN",
    "Network",
    "admits",
    "check_host",
    "check_port",
    "is_loopback",
    "parse_listen",
    "parse_networks",
    "tcp_url",
    "warn_remote",
]

Network = ipaddress.IPv4Network | ipaddress.IPv6Network

DEFAULT_LISTEN = "127.0.0.1:9100"

log = logging.getLogger(__name__)


def is_loopback(host: str) -> bool:
    """Whether every address ``host`` names is a loopback address."""
    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except socket.gaierror:
        return False
    addresses = {info[4][0] for info in infos}
    return bool(addresses) and all(
        ipaddress.ip_address(str(a).split("%")[0]).is_loopback for a in addresses
    )


def check_host(host: str, allow_remote: bool) -> None:
    if not isinstance(host, str) or not host:
        raise UsageError(f"host: {host!r} is not a host name or address")
    if not allow_remote and not is_loopback(host):
        raise UsageError(
            f"host: {host!r} is not a loopback address; only this machine is served "
            "unless allow_remote=True (--allow-remote)"
        )


def check_port(port: int) -> None:
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise UsageError(f"port: {port!r} is not 0..65535 (0 picks a free port)")


def parse_listen(text: str) -> tuple[str, int]:
    """``"HOST:PORT"``, ``"[v6addr]:PORT"`` or a bare ``"PORT"`` (on 127.0.0.1)."""
    text = text.strip()
    if text.isdigit():
        host, port_text = "127.0.0.1", text
    elif text.startswith("["):
        inside, sep, port_text = text[1:].partition("]:")
        host = inside
        if not sep:
            raise UsageError(f"listen: {text!r} is not [ADDRESS]:PORT")
    else:
        host, sep, port_text = text.rpartition(":")
        if not sep or not host:
            raise UsageError(f"listen: {text!r} is not HOST:PORT (e.g. {DEFAULT_LISTEN})")
    if not port_text.isdigit():
        raise UsageError(f"listen: {port_text!r} in {text!r} is not a port number")
    port = int(port_text)
    check_port(port)
    return host, port


def tcp_url(host: str, port: int) -> str:
    return f"tcp://[{host}]:{port}" if ":" in host else f"tcp://{host}:{port}"


def warn_remote(host: str, port: int, what: str) -> None:
    """Say loudly (stderr and the log) that ``host:port`` is open beyond this machine."""
    if is_loopback(host):
        return
    text = (
        f"warning: serving on {host}:{port}, which is not a loopback address: "
        f"any machine that can reach it can {what}"
    )
    print(text, file=sys.stderr, flush=True)
    log.warning(text)


def parse_networks(items: object, where: str = "allow_from") -> tuple[Network, ...]:
    """``["192.0.2.7", "198.51.100.0/24", "2001:db8::/32"]`` as networks (a bare address is one
    host); a UsageError naming ``where`` (the option, e.g. ``modbus.allow_from``) when wrong."""
    if isinstance(items, str | bytes | Mapping) or not isinstance(items, Iterable):
        raise UsageError(f"{where}: {items!r} is not a list of addresses or networks")
    networks: list[Network] = []
    for item in items:
        try:
            networks.append(ipaddress.ip_network(str(item).strip(), strict=False))
        except ValueError:
            raise UsageError(
                f"{where}: {item!r} is not an address or network (e.g. 192.0.2.7, 10.1.0.0/16)"
            ) from None
    return tuple(networks)


def admits(allow_from: tuple[Network, ...] | None, peername: object) -> bool:
    """Whether a peer at ``peername`` (a socket address) is served: loopback always, others only
    when ``allow_from`` names them (None: everyone the listener's address reaches)."""
    if allow_from is None:
        return True
    if not isinstance(peername, tuple) or not peername:
        return False
    try:
        address = ipaddress.ip_address(str(peername[0]).split("%")[0])
    except ValueError:
        return False
    if isinstance(address, ipaddress.IPv6Address) and address.ipv4_mapped is not None:
        address = address.ipv4_mapped
    return address.is_loopback or any(address in network for network in allow_from)
