"""The jog pad keeps listening while its own goto (`g NUMBER Enter y`) runs.

The pad used to run the whole move inside its key loop: space ("stop now") and q did nothing,
the screen was not redrawn, and keys typed meanwhile were read only after the move, so a jog key
tapped during it jogged the robot by itself afterwards.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from robostar.cli.jogpad import JogPad, Quit, StopMove
from robostar.client import Client
from robostar.sim import SimConfig, VirtualController
from robostar.sim.listeners import PeerHost
from robostar.types import PositionKind

pytestmark = pytest.mark.timeout(120)


def test_only_stop_keys_count_while_the_pad_moves() -> None:
    pad = JogPad(axes=4, speed=300, teaching=True, moving=True)
    for key in ("right", "d", "left", "1", "tab", "up", "m", "t", "g", "y", "enter"):
        assert pad.key(key, 0.0) == [], key
    assert pad.jogging is None and pad.entry is None and pad.speed == 300
    assert pad.key("space", 0.0) == [StopMove()]
    assert not pad.moving
    pad.moving = True
    assert pad.key("q", 0.0) == [StopMove(), Quit()]


@pytest.fixture
def homed_line() -> Iterator[str]:
    """A real-time simulator on 127.0.0.1, homed, so that a goto takes a few seconds."""
    controller = VirtualController(SimConfig(speedup=1))
    host = PeerHost(controller, name="goto")
    address = host.listen_tcp("127.0.0.1", 0)
    host.start()
    url = f"tcp://{address[0]}:{address[1]}"
    try:
        with Client(url) as client:
            client.servo(1, True)
            client.home(1, wait=True, timeout=60)
            client.wait_stopped(1, 60)
        yield url
    finally:
        host.close()


def _ask_goto(term: Any) -> None:
    term.wait_for("robostar jog")
    for key in ("g", "3", "\r"):
        term.send(key)
        term.pump(0.1)
    term.wait_for("y/n")
    term.send("y")


def test_space_stops_a_pad_goto(terminal: Any, homed_line: str) -> None:
    term = terminal("--port", homed_line, "jog", "--teach", "DEMO.PNT")
    _ask_goto(term)
    term.wait_for("moving to")  # the screen is redrawn while the move runs
    term.pump(0.4)
    term.send(" ")  # space: stop now
    term.wait_for("emergency stop (CF)")
    with Client(homed_line) as client:
        samples = []
        for _ in range(4):
            samples.append(client.position(1, PositionKind.ANGLE).axes[0])
            term.pump(0.3)  # keep reading the screen: a pad whose output blocks drops keys
        assert len(set(samples)) == 1, f"the robot moved on after space: {samples}"
        assert any(a.code == 9001 for a in client.alarms())  # Host Emergency: CF was sent
        assert client.speed(1) == 300  # the pad's goto speed was put back
    term.send("q")
    assert term.wait_exit(30) == 0


def test_keys_typed_during_a_pad_goto_are_not_replayed_after_it(
    terminal: Any, homed_line: str
) -> None:
    term = terminal("--port", homed_line, "jog", "--teach", "DEMO.PNT")
    _ask_goto(term)
    term.wait_for("moving to")
    term.send("d")  # a tap on jog + while the goto runs, let go at once
    term.wait_for("at point 3 of DEMO.PNT", timeout=60)
    with Client(homed_line) as client:
        arrived = client.position(1, PositionKind.ANGLE).axes[0]
        for _ in range(5):
            term.pump(0.2)
            assert client.position(1, PositionKind.ANGLE).axes[0] == arrived, "a stale jog"
    term.send("q")
    assert term.wait_exit(30) == 0


def test_keys_typed_with_the_question_do_not_answer_it(terminal: Any, sim_line: Any) -> None:
    term = terminal("--port", sim_line.url, "jog", "--teach", "DEMO.PNT")
    term.wait_for("robostar jog")
    term.send("g3\ry")  # typed ahead in one go: the "y" came before the question was shown
    term.wait_for("y/n")
    term.pump(0.5)
    assert "y/n" in term.text() and "moving" not in term.text() and "refused" not in term.text()
    term.send("n")
    term.wait_for("cancelled")
    term.send("q")
    assert term.wait_exit(30) == 0
