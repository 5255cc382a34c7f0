"""Ctrl-C exits 130 after stopping the motion the command started."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from typing import Any

import pytest

from robostar.client import Client


@pytest.fixture
def slow_line() -> Iterator[tuple[Any, str]]:
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.server import PeerHost

    controller = VirtualController(SimConfig(speedup=1))
    host = PeerHost(controller, name="interrupt-test")
    address = host.listen_tcp("127.0.0.1", 0)
    host.start()
    try:
        yield controller, f"tcp://{address[0]}:{address[1]}"
    finally:
        host.close()


def test_ctrl_c_stops_the_move_it_started(terminal: Any, slow_line: tuple[Any, str]) -> None:
    _controller, url = slow_line
    with Client(url) as client:
        client.servo(1, True)
        client.home(1, wait=True, timeout=60)
        client.set_speed(1, 20)
    term = terminal("--port", url, "move", "90", "90", "0", "0")
    term.wait_for("will move")  # the warning before the motion
    with Client(url) as client:
        for _ in range(200):
            if not client.status()[0].in_position:
                break
    # The terminal's job on Ctrl-C (the test's pty is not the process's controlling terminal).
    term.process.send_signal(signal.SIGINT)
    code = term.wait_exit()
    assert code == 130, term.text()
    said = " ".join(term.text().split())
    assert "Interrupted; stopped the move of channel 1 with an emergency stop (CF)" in said
    with Client(url) as client:
        assert client.status()[0].alarm  # the emergency stop's alarm, as the message says
        before = client.position(1, "angle").axes
        client.status()
        assert client.position(1, "angle").axes == before  # it no longer moves
        assert before[:2] != (90.0, 90.0)
