"""A simulator out of file descriptors rests its listener instead of spinning, and goes on serving.

The simulator runs in a child process with a low descriptor limit; this process opens more
connections than it can accept.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import textwrap

import pytest

from robostar import Client

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="counts descriptors in /proc"
)

CHILD = textwrap.dedent(
    """
    import logging, os, resource, sys
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.listeners import SimServer

    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    with SimServer(VirtualController(SimConfig()), max_clients=1000) as server:
        in_use = len(os.listdir("/proc/self/fd"))
        # Room for the first client and two more; the rest wait in the listen backlog.
        resource.setrlimit(resource.RLIMIT_NOFILE, (in_use + 3, in_use + 3))
        print(server.url, flush=True)
        sys.stdin.readline()
        print(server.accept_failures, server.running, flush=True)
    """
)


def test_out_of_descriptors_the_listener_backs_off_and_peers_are_still_served() -> None:
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    extra: list[socket.socket] = []
    try:
        assert child.stdout is not None and child.stdin is not None
        url = child.stdout.readline().strip()
        host, port = url.removeprefix("tcp://").rsplit(":", 1)
        with Client(url, timeout=2.0) as client:
            assert len(client.status()) == 3
            for _ in range(8):
                extra.append(socket.create_connection((host, int(port)), timeout=5.0))
            for _ in range(5):  # served all along, with the listener out of descriptors
                assert len(client.status()) == 3
        for sock in extra:
            sock.close()
        extra.clear()
        with Client(url, timeout=2.0) as late:  # accepted once descriptors are free again
            assert len(late.status()) == 3
        child.stdin.write("\n")
        child.stdin.flush()
        failures, running = child.stdout.readline().split()
        stderr = child.communicate(timeout=10)[1]
    finally:
        for sock in extra:
            sock.close()
        if child.poll() is None:
            child.kill()
            child.wait()
    assert running == "True"
    assert 1 <= int(failures) < 100  # a spinning accept loop fails thousands of times
    assert stderr.count("cannot accept") == 1
