"""Who is at the other end of an N1 connection, for the audit log.

The N1 host protocol carries no user name (a host program opens the port and sends commands), so
a console's connection would be known only by its address (``127.0.0.1:51394``). When the peer
is on this machine, Linux knows more: the peer's socket is a row of ``/proc/net/tcp`` (or
``tcp6``) whose local address is the peer's address, with the uid that owns it and an inode that
one of the owner's processes has open. :func:`describe_peer` names the user from that uid and,
when this server may look into that process (the same user, or root), its command and pid:
``127.0.0.1:51394 (olga, robostar pid 4242)``. Anywhere else (another machine, another network
namespace, no ``/proc``) the address alone is the name. Over mutual TLS the client certificate's
common name is the name the console sends, and comes first.

Reading ``/proc/net/tcp`` and the processes' descriptors takes tens of milliseconds on a busy
machine, so :func:`find_owner` blocks: an event loop runs it in a worker thread (the N1 face's
host does) and names the connection from its answer with :func:`peer_name`;
:func:`describe_peer` is both in one blocking call. At most :data:`LOOKUPS_PER_SECOND` connections
a second are looked up (:func:`lookup_due` counts them: a loop of connections from a local
program must not keep threads busy reading ``/proc``); past that a connection is named by its
address.
"""

from __future__ import annotations

import collections
import ipaddress
import os
import pwd
import sys
import time
from dataclasses import dataclass
from pathlib import Path

__all__ = ["PeerOwner", "describe_peer", "find_owner", "lookup_due", "peer_name"]

LOOKUPS_PER_SECOND = 5
"""Connections a second whose local owner is looked up; the others keep their address."""
_ESTABLISHED = "01"
_MAX_PROCESSES = 4096
"""Processes looked into at most for the socket's inode (a connection must not wait long)."""

Address = ipaddress.IPv4Address | ipaddress.IPv6Address


@dataclass(frozen=True)
class PeerOwner:
    """The local user (and, when visible, process) holding a peer's socket."""

    user: str
    pid: int | None = None
    command: str | None = None

    def __str__(self) -> str:
        if self.pid is None:
            return self.user
        return f"{self.user}, {self.command or '?'} pid {self.pid}"


def describe_peer(address: object, *, common_name: str | None = None) -> str:
    """The name of a connection's peer (``peername``) for logs and the audit log: its address,
    with the certificate's common name or the local user and process that holds it when known.
    Blocking (it may read ``/proc``): on an event loop, run :func:`find_owner` in a thread."""
    due = lookup_due(address, common_name=common_name)
    owner = None if due is None else find_owner(*due)
    return peer_name(address, common_name=common_name, owner=owner)


def peer_name(
    address: object, *, common_name: str | None = None, owner: PeerOwner | None = None
) -> str:
    """``HOST:PORT``, followed by the certificate's common name or the local owner when given."""
    if not isinstance(address, tuple) or len(address) < 2:
        return str(address)
    name = f"{address[0]}:{int(address[1])}"
    known = common_name or owner
    return name if not known else f"{name} ({known})"


def lookup_due(address: object, *, common_name: str | None = None) -> tuple[str, int] | None:
    """The ``(host, port)`` whose local owner :func:`find_owner` should look for now, or None
    when there is nothing to look up (a certificate names the peer, the peer is on another
    machine) or this second's lookups are spent. A lookup it returns is counted."""
    if common_name or not isinstance(address, tuple) or len(address) < 2:
        return None
    host, port = str(address[0]), int(address[1])
    if _loopback(host) is None or not _may_look_up(time.monotonic()):
        return None
    return host, port


_lookups: collections.deque[float] = collections.deque(maxlen=LOOKUPS_PER_SECOND)


def _may_look_up(now: float) -> bool:
    """True (and counted) while fewer than :data:`LOOKUPS_PER_SECOND` were made this second."""
    if len(_lookups) == _lookups.maxlen and now - _lookups[0] < 1.0:
        return False
    _lookups.append(now)
    return True


def find_owner(host: str, port: int, proc: Path = Path("/proc")) -> PeerOwner | None:
    """The user (and process) of this machine whose socket is bound to ``host:port``, or None
    (not a loopback peer, not Linux, not found)."""
    ip = _loopback(host)
    if ip is None:
        return None  # its socket is on another machine
    found = _socket_row(ip, port, proc)
    if found is None:
        return None
    uid, inode = found
    try:
        user = pwd.getpwuid(uid).pw_name
    except KeyError:
        user = f"uid {uid}"
    pid = _process_of(inode, uid, proc)
    if pid is None:
        return PeerOwner(user)
    try:
        command = (proc / str(pid) / "comm").read_text().strip()
    except OSError:
        command = None
    return PeerOwner(user, pid, command)


def _loopback(host: str) -> Address | None:
    """``host`` as a loopback address (an IPv4-mapped one as IPv4), or None."""
    try:
        ip: Address = ipaddress.ip_address(host.split("%", 1)[0])
    except ValueError:
        return None
    if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
        ip = ip.ipv4_mapped
    return ip if ip.is_loopback else None


def _socket_row(ip: Address, port: int, proc: Path) -> tuple[int, int] | None:
    """(uid, inode) of the established socket whose local address is ``ip:port``: the rows
    are matched on their text (the address as ``/proc/net/tcp`` writes it), not parsed."""
    for table, wanted in (("tcp", _proc_texts(ip, port, 4)), ("tcp6", _proc_texts(ip, port, 6))):
        if not wanted:
            continue
        try:
            lines = (proc / "net" / table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split(maxsplit=10)
            if len(fields) >= 10 and fields[1] in wanted and fields[3] == _ESTABLISHED:
                return int(fields[7]), int(fields[9])
    return None


def _proc_texts(ip: Address, port: int, family: int) -> set[str]:
    """How ``/proc/net/tcp`` (``family`` 4) or ``tcp6`` (6) writes ``ip:port``: the address's
    32-bit words each in this machine's byte order, in hex, then the port in hex; an IPv4
    address in tcp6 as its IPv4-mapped form."""
    if family == 4:
        packed = [ip.packed] if isinstance(ip, ipaddress.IPv4Address) else []
    elif isinstance(ip, ipaddress.IPv4Address):
        packed = [ipaddress.IPv6Address(b"\0" * 10 + b"\xff\xff" + ip.packed).packed]
    else:
        packed = [ip.packed]
    texts = set()
    for raw in packed:
        words = [raw[i : i + 4] for i in range(0, len(raw), 4)]
        if sys.byteorder == "little":
            words = [w[::-1] for w in words]
        texts.add(f"{b''.join(words).hex().upper()}:{port:04X}")
    return texts


def _process_of(inode: int, uid: int, proc: Path) -> int | None:
    """The pid of a process of ``uid`` that has socket ``inode`` open, if this server may see
    it (its own user's processes, or all as root)."""
    if os.geteuid() not in (0, uid):
        return None
    wanted = f"socket:[{inode}]"
    looked = 0
    # the newest first: a console or host program that just connected is most likely recent
    pids = sorted((int(e.name) for e in proc.iterdir() if e.name.isdigit()), reverse=True)
    for pid in pids:
        entry = proc / str(pid)
        looked += 1
        if looked > _MAX_PROCESSES:
            return None
        try:
            if entry.stat().st_uid != uid:
                continue
            for fd in (entry / "fd").iterdir():
                if os.readlink(fd) == wanted:
                    return pid
        except OSError:
            continue  # gone, or not ours to look into
    return None
