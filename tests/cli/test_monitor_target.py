"""The full-screen monitor names its target in its title (the banner on stderr is hidden by the
alternate screen)."""

from __future__ import annotations

from typing import Any

from .conftest import RealControllerStandIn


def test_a_simulators_monitor_says_so(terminal: Any) -> None:
    term = terminal("--port", "sim://?speedup=20", "monitor", "--rate", "5")
    term.wait_for("line OK")
    title = term.line_with("robostar monitor")
    assert "SIMULATOR | sim://?speedup=20" in title, term.text()
    term.send("q")
    assert term.wait_exit() == 0


def test_a_controllers_monitor_says_so(terminal: Any, served: Any) -> None:
    url = served(RealControllerStandIn())
    term = terminal("--port", url, "monitor", "--rate", "5")
    term.wait_for("line OK")
    title = term.line_with("robostar monitor")
    assert f"controller | {url}" in title, term.text()
    assert "SIMULATOR" not in term.text()
    term.send("q")
    assert term.wait_exit() == 0
