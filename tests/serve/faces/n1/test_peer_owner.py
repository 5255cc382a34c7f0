"""An N1 console or host program on this machine is named by its user and process in the line
server's lease and audit log (``n1:127.0.0.1:PORT (user, command pid N)``), not by its address
alone; a peer elsewhere keeps its address as its name."""

from __future__ import annotations

import asyncio
import os
import pwd
import socket
import time
from pathlib import Path

import pytest

from robostar.client import Client
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.n1 import peer_owner
from robostar.serve.faces.n1.peer_owner import describe_peer, find_owner, lookup_due, peer_name


@pytest.fixture(autouse=True)
def lookups_allowed() -> None:
    """Each test starts with this second's lookup budget unspent (other tests connect too)."""
    peer_owner._lookups.clear()


ME = pwd.getpwuid(os.geteuid()).pw_name
COMMAND = Path("/proc/self/comm").read_text().strip()


def test_a_local_peer_is_found_by_its_socket() -> None:
    for family, host in ((socket.AF_INET, "127.0.0.1"), (socket.AF_INET6, "::1")):
        with socket.create_server((host, 0), family=family) as server:
            client = socket.create_connection(server.getsockname()[:2])
            accepted, peer = server.accept()
            with client, accepted:
                owner = find_owner(peer[0], peer[1])
                assert owner is not None, host
                assert (owner.user, owner.pid, owner.command) == (ME, os.getpid(), COMMAND)
                shown = f"{peer[0]}:{peer[1]} ({ME}, {COMMAND} pid {os.getpid()})"
                assert describe_peer(peer) == shown


def test_a_remote_peer_keeps_its_address() -> None:
    assert find_owner("192.0.2.7", 51394) is None
    assert describe_peer(("192.0.2.7", 51394)) == "192.0.2.7:51394"
    assert describe_peer(("192.0.2.7", 51394), common_name="mes-7") == "192.0.2.7:51394 (mes-7)"


def test_an_n1_host_program_holds_control_under_its_user() -> None:
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.5),),
        faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
    )

    async def main() -> None:
        async with LineServer(config) as server:
            host, port = server.faces["n1"].addresses["cell1"]  # type: ignore[attr-defined]
            line = server.lines["cell1"]

            def host_program() -> str | None:
                with Client(f"tcp://{host}:{port}", timeout=5.0) as n1:
                    n1.set_speed(1, 40)  # a host program's write keeps control
                    return line.control().holder

            holder = await asyncio.to_thread(host_program)
            assert holder is not None and holder.startswith("n1:127.0.0.1:")
            assert holder.endswith(f" ({ME}, {COMMAND} pid {os.getpid()})"), holder

    asyncio.run(main())


def test_only_local_peers_are_looked_up_at_most_five_a_second(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A lookup is work for a thread: none for a peer elsewhere or one a certificate names,
    and at most five a second."""
    now = [1000.0]
    monkeypatch.setattr(time, "monotonic", lambda: now[0])
    assert lookup_due(("192.0.2.7", 51394)) is None
    assert lookup_due(("127.0.0.1", 51394), common_name="mes-7") is None
    due = [lookup_due(("127.0.0.1", port)) for port in range(1, 8)]
    assert due == [("127.0.0.1", port) for port in range(1, 6)] + [None, None]
    now[0] += 1.0
    assert lookup_due(("::ffff:127.0.0.1", 9)) == ("::ffff:127.0.0.1", 9)


def test_a_peer_is_named_by_its_certificate_or_its_owner() -> None:
    owner = peer_owner.PeerOwner("olga", 4242, "robostar")
    assert peer_name(("127.0.0.1", 51394)) == "127.0.0.1:51394"
    assert (
        peer_name(("127.0.0.1", 51394), owner=owner) == "127.0.0.1:51394 (olga, robostar pid 4242)"
    )
    assert peer_name(("::1", 7, 0, 0), common_name="mes-7") == "::1:7 (mes-7)"
