"""After an error the jog pad stops the jog that runs and knows what still jogs.

Every error branch of the pad's runner used to drop the running jog's context without closing
it: a failed speed change left its keepalive sending BF (the robot jogged on with no key held),
and a reversal whose BG answer was lost started the new jog while the pad believed nothing
jogged, so releasing the key never stopped it. The real runner on the
built-in simulator; the failures are injected.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from robostar.cli.jogpad import JogPad, StartJog, StopJog, _PadRunner, _View
from robostar.cli.session import ConsoleSession, Settings
from robostar.commands.control import SetSpeed
from robostar.commands.motion import JogStop
from robostar.commands.status import ReadPosition
from robostar.errors import ReplyTimeoutError
from robostar.types import JogDirection, PositionKind

pytestmark = pytest.mark.timeout(60)


@pytest.fixture
def session() -> Iterator[ConsoleSession]:
    _OTHERS.clear()
    _OTHERS.update(threading.enumerate())
    session = ConsoleSession(Settings("sim://", None, False, None, 1, False))
    session.client.execute(SetSpeed(1, 50))
    try:
        yield session
    finally:
        session.close()


def _axis(session: ConsoleSession) -> float:
    return session.client.execute(ReadPosition(1, PositionKind.ANGLE)).axes[0]


_OTHERS: set[threading.Thread] = set()
"""Keepalive threads of other tests, still ending, which are none of these tests' business."""


def _keepalives() -> list[str]:
    return [
        t.name
        for t in threading.enumerate()
        if t.name.startswith("robostar jog") and t not in _OTHERS
    ]


def _still(session: ConsoleSession, seconds: float = 0.6) -> bool:
    before = _axis(session)
    time.sleep(seconds)
    return _axis(session) == before


def test_a_failed_speed_change_while_jogging_stops_the_jog(
    session: ConsoleSession, monkeypatch: Any
) -> None:
    client = session.client
    real_execute = client.execute

    def execute(command: Any, *args: Any, **kwargs: Any) -> Any:
        if isinstance(command, SetSpeed):
            raise ReplyTimeoutError("CB", 2.0, "injected")
        return real_execute(command, *args, **kwargs)

    pad = JogPad(axes=4, speed=50)
    runner = _PadRunner(session, pad, _View(1, "test"), 0.2)
    for action in pad.key("right", time.monotonic()):
        runner.apply(action)
    time.sleep(0.2)
    assert _keepalives()
    monkeypatch.setattr(client, "execute", execute)
    for action in pad.key("up", time.monotonic()):  # speed +50 while jogging: CB fails
        runner.apply(action)
    monkeypatch.setattr(client, "execute", real_execute)
    assert "line failed" in runner.view.message.plain
    assert pad.jogging is None
    assert _keepalives() == []  # no orphan keepalive thread
    time.sleep(0.1)
    assert _still(session), "the robot jogged on after the failed speed change"
    runner.close()


def test_a_reversal_whose_bg_answer_is_lost_is_still_tracked(
    session: ConsoleSession, monkeypatch: Any
) -> None:
    client = session.client
    real_call = client._call
    lost: list[Any] = []

    def call(command: Any, *args: Any, **kwargs: Any) -> Any:
        if isinstance(command, JogStop) and not lost:
            lost.append(command)
            real_call(command, *args, **kwargs)  # BG reaches the controller, its answer is lost
            raise ReplyTimeoutError("BG", 2.0, "injected")
        return real_call(command, *args, **kwargs)

    pad = JogPad(axes=4, speed=50)
    runner = _PadRunner(session, pad, _View(1, "test"), 0.2)
    for action in pad.key("right", time.monotonic()):
        runner.apply(action)
    time.sleep(0.2)
    monkeypatch.setattr(client, "_call", call)
    actions = pad.key("left", time.monotonic())
    assert actions == [StopJog(), StartJog(1, JogDirection.MINUS)]
    for action in actions:
        runner.apply(action)
    assert lost, "the injected fault did not happen"
    assert pad.jogging is JogDirection.MINUS  # the new jog runs, and the pad knows it
    deadline = pad.next_deadline()
    assert deadline is not None
    assert len(_keepalives()) == 1
    time.sleep(max(deadline - time.monotonic(), 0.0))
    for action in pad.tick(time.monotonic()):  # the left key was let go: the pad stops it
        runner.apply(action)
    assert pad.jogging is None
    assert _keepalives() == []
    time.sleep(0.1)
    assert _still(session), "the robot jogged on after the key was let go"
    runner.close()
