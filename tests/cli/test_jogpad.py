"""The jog pad's logic with a fake clock: held keys jog, released keys stop, leaving stops."""

from __future__ import annotations

from robostar.cli.jogpad import ChangeSpeed, JogPad, Quit, StartJog, StopJog, ToggleMotion
from robostar.cli.keys import parse_keys
from robostar.types import JogDirection, MotionType

PLUS = JogDirection.PLUS
MINUS = JogDirection.MINUS


def pad() -> JogPad:
    return JogPad(axes=4, speed=300, hold=0.5, repeat_hold=0.2)


def test_a_held_key_jogs_until_its_repeats_stop() -> None:
    p = pad()
    assert p.key("right", 0.0) == [StartJog(1, PLUS)]
    # Before the keyboard's autorepeat starts, the first press holds the jog.
    assert p.tick(0.45) == []
    for t in (0.5, 0.53, 0.56, 0.6):
        assert p.key("right", t) == []
        assert p.tick(t) == []
    assert p.tick(0.79) == []
    assert p.tick(0.8) == [StopJog()]
    assert p.jogging is None
    assert p.next_deadline() is None


def test_a_tap_jogs_for_the_hold_window_only() -> None:
    p = pad()
    p.key("left", 10.0)
    assert p.next_deadline() == 10.5
    assert p.tick(10.5) == [StopJog()]


def test_reversing_changing_axis_and_leaving_stop_the_jog_first() -> None:
    p = pad()
    p.key("right", 0.0)
    assert p.key("left", 0.1) == [StopJog(), StartJog(1, MINUS)]
    assert p.key("2", 0.2) == [StopJog()]
    assert p.axis == 2
    p.key("d", 0.3)
    assert p.key("tab", 0.4) == [StopJog()]
    assert p.axis == 3
    p.key("a", 0.5)
    assert p.key("m", 0.6) == [StopJog(), ToggleMotion(MotionType.LINEAR)]
    p.key("right", 0.7)
    assert p.key("space", 0.8) == [StopJog()]
    p.key("right", 0.9)
    assert p.key("q", 1.0) == [StopJog(), Quit()]
    assert p.key("esc", 1.1) == [Quit()]


def test_axis_keys_beyond_the_robot_are_ignored() -> None:
    p = pad()
    assert p.key("6", 0.0) == []
    assert p.axis == 1
    p.key("4", 0.0)
    p.key("tab", 0.0)
    assert p.axis == 1


def test_speed_steps_and_clamps() -> None:
    p = JogPad(axes=2, speed=980)
    assert p.key("up", 0.0) == [ChangeSpeed(1000)]
    assert p.key("+", 0.0) == []
    p = JogPad(axes=2, speed=30)
    assert p.key("down", 0.0) == [ChangeSpeed(0)]
    assert p.key("-", 0.0) == []


def test_keys_from_terminal_bytes() -> None:
    assert parse_keys("\x1b[C\x1b[D\x1bOA\x1b[B") == ["right", "left", "up", "down"]
    assert parse_keys("q\t 3\x03") == ["q", "tab", "space", "3", "ctrl-c"]
    assert parse_keys("\x1b") == ["esc"]
    assert parse_keys("\x1b[15~x") == ["x"]  # F5 is skipped whole
