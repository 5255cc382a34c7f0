"""The jog pad stops the robot even when its own screen output blocks.

The pad notices a released key in its screen loop; the BF keepalive runs on a thread of its
own. Ctrl-S (XOFF: cbreak mode leaves IXON on) or a backed-up SSH session blocks the pad's
screen write, and with it the loop: the jog's dead-man's switch (the pad's key-hold deadline)
must stop the jog from the keepalive thread.
"""

from __future__ import annotations

import time
from typing import Any

import pytest

from robostar.client import Client
from robostar.sim import SimConfig, VirtualController
from robostar.sim.listeners import PeerHost
from robostar.types import PositionKind

pytestmark = pytest.mark.timeout(90)

RIGHT = "\x1b[C"


def test_ctrl_s_while_jogging_does_not_keep_the_robot_moving(terminal: Any) -> None:
    controller = VirtualController(SimConfig(speedup=1))  # real time: the hold is 0.55 s
    host = PeerHost(controller, name="xoff")
    address = host.listen_tcp("127.0.0.1", 0)
    host.start()
    url = f"tcp://{address[0]}:{address[1]}"
    try:
        term = terminal("--port", url, "jog", "--speed", "50")
        term.wait_for("robostar jog")
        term.pump(0.5)
        term.send(RIGHT)  # a single tap: the pad should jog for --hold (0.55 s) only
        term.send("\x13")  # Ctrl-S right after: the pad's next screen write blocks
        trail = []
        started = time.monotonic()
        with Client(url) as client:
            while time.monotonic() - started < 3.0:
                axis = client.position(1, PositionKind.ANGLE).axes[0]
                trail.append((round(time.monotonic() - started, 1), round(axis, 2)))
                term.pump(0.25)  # the test keeps reading the terminal all along
            assert trail[-1][1] != 0.0, f"the tap did not jog at all: {trail}"
            late = {axis for t, axis in trail if t >= 1.3}  # hold 0.55 s + grace 0.3 s
            assert len(late) == 1, f"the robot moved on with no key held: {trail}"
            term.send("d")  # a tap typed while the screen is held: stale once it flows
            term.pump(0.3)
            term.send("\x11")  # Ctrl-Q: the screen flows again
            term.wait_for("the jog stopped: the pad fell behind")
            stopped = client.position(1, PositionKind.ANGLE).axes[0]
            for _ in range(4):
                term.pump(0.25)
                assert client.position(1, PositionKind.ANGLE).axes[0] == stopped, "a stale jog"
        term.send("q")
        assert term.wait_exit(30) == 0
    finally:
        host.close()
