"""Helpers for the web face's tests: the stack they run against, and signing in.

The web face for real: a simulator on a loopback TCP port, the line server in front of it, and
the dashboard served by uvicorn on a free loopback port, all on an event loop of their own.

Tests talk to the dashboard over HTTP (httpx), WebSocket (websockets) and a real browser
(Playwright driving Debian's Chromium); they change the simulated world directly through the
simulator's model (holding the simulator host's lock) and read back what the controller did.
"""

from __future__ import annotations

import asyncio
import json
import re
import shutil
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import httpx
import pytest

pytest.importorskip("starlette", reason="the web face needs the 'web' extra")

from robostar.serve.faces.web import WebFace
from robostar.serve.line_server import LineServer
from robostar.serve.users import Role
from robostar.sim import VirtualController
from robostar.sim.listeners import SimServer

T = TypeVar("T")

PASSWORDS = {"olga": "operator-pass", "vic": "viewer-pass", "erin": "engineer-pass"}
ROLES = {"olga": Role.OPERATOR, "vic": Role.VIEWER, "erin": Role.ENGINEER}
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"


@dataclass
class Stack:
    """One simulator, one line server with the web face, and the loop they run on."""

    controller: VirtualController
    sim: SimServer
    server: LineServer
    face: WebFace
    loop: asyncio.AbstractEventLoop
    audit_path: Path

    @property
    def url(self) -> str:
        return self.face.url

    @property
    def line(self) -> Any:
        return self.server.lines["cell1"]

    def call(self, coro: Any, timeout: float = 10.0) -> Any:
        """Run a coroutine on the stack's loop and wait for its result."""
        future: Future[Any] = asyncio.run_coroutine_threadsafe(coro, self.loop)
        return future.result(timeout)

    def in_sim(self, change: Callable[[VirtualController], T]) -> T:
        """Change the simulated controller as its own thread would (holding its lock)."""
        with self.sim.lock:
            result = change(self.controller)
        self.sim.wake()
        return result


def wait_until(check: Callable[[], object], timeout: float = 10.0, what: str = "") -> None:
    """Wait for ``check()`` to hold, polled (``timeout`` only ends a wait that would fail)."""
    end = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < end, f"never: {what or 'the condition'}"
        time.sleep(0.02)


def expect(target: Any) -> Any:
    """Playwright's ``expect(target)``, its waiting assertions (imported here, not at the top:
    the HTTP tests run without Playwright)."""
    from playwright.sync_api import expect as playwright_expect

    return playwright_expect(target)


def confirm(page: Any, text: str) -> None:
    """Answer the dashboard's confirmation dialog with OK, once it says ``text``."""
    page.locator("#confirm").wait_for(state="visible")
    assert text in page.locator("#confirm-text").inner_text()
    page.click("#confirm-ok")


def sign_in(page: Any, user: str) -> None:
    """Sign ``user`` in through the dashboard's login form in a browser page."""
    page.goto("/login")
    page.fill("input[name=username]", user)
    page.fill("input[name=password]", PASSWORDS[user])
    page.click("form.login button[type=submit]")
    page.wait_for_url("**/")


def login(client: httpx.Client, user: str) -> str:
    """Sign ``user`` in; returns the session's CSRF token."""
    page = client.get("/login")
    token = csrf_of(page.text)
    answer = client.post(
        "/login",
        data={"csrf_token": token, "username": user, "password": PASSWORDS[user]},
        follow_redirects=False,
    )
    assert answer.status_code == 303, answer.text
    return csrf_of(client.get("/").text)


def ask(socket: Any, message: dict[str, Any]) -> dict[str, Any]:
    """Send ``message`` on the jog socket; its answer."""
    socket.send(json.dumps(message))
    answer: dict[str, Any] = json.loads(socket.recv(timeout=10))
    return answer


def csrf_of(html: str) -> str:
    match = re.search(r'<meta name="csrf-token" content="([^"]+)"', html)
    assert match, "no CSRF token in the page"
    return match.group(1)
