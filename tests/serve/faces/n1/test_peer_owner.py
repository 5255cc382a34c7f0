"""An N1 console or host program on this machine is named by its user and process in the line
server's lease and audit log (``n1:127.0.0.1:PORT (user, command pid N)``), not by its address
alone; a peer elsewhere keeps its address as its name."""

from __future__ import annotations

import asyncio
import os
import pwd
import socket
from pathlib import Path

import pytest

from robostar.client import Client
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.n1 import peer_owner
from robostar.serve.faces.n1.peer_owner import describe_peer, find_owner


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
