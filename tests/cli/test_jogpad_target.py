"""The full-screen jog pad names its target in its title: the SIMULATOR / controller banner goes
to stderr before the pad switches to the alternate screen, which hides it for as long as the
pad runs, so a simulator's pad looked like a robot's."""

from __future__ import annotations

from typing import Any

from .conftest import RealControllerStandIn


def test_a_simulators_pad_says_so(terminal: Any) -> None:
    term = terminal("--port", "sim://?speedup=20", "jog")
    term.wait_for("robostar jog")
    term.pump(0.3)
    title = term.line_with("robostar jog")
    assert "SIMULATOR | sim://?speedup=20" in title, term.text()
    term.send("q")
    assert term.wait_exit() == 0


def test_a_controllers_pad_says_so(terminal: Any, served: Any) -> None:
    url = served(RealControllerStandIn())
    term = terminal("--port", url, "jog")
    term.wait_for("robostar jog")
    term.pump(0.3)
    title = term.line_with("robostar jog")
    assert f"controller | {url}" in title, term.text()
    assert "SIMULATOR" not in term.text()
    term.send("q")
    assert term.wait_exit() == 0
