"""Fixtures of the web face's tests (see web_harness for what they start)."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

pytest.importorskip("starlette", reason="the web face needs the 'web' extra")

from web_harness import CHROMIUM, PASSWORDS, ROLES, Stack, login

from robostar.commands.files import LINE_MAX
from robostar.commands.job import MAX_STEP
from robostar.controller_role import UploadLimits
from robostar.serve.config import LineConfig, ServeConfig
from robostar.serve.faces.web import WebFace
from robostar.serve.line_server import LineServer
from robostar.serve.users import UserStore
from robostar.sim import SimConfig, VirtualController
from robostar.sim.listeners import SimServer


@pytest.fixture(scope="module")
def users_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("web") / "users.toml"
    store = UserStore(path)
    for name, password in PASSWORDS.items():
        store.add(name, ROLES[name], password)
    return path


@pytest.fixture(scope="module")
def stack(users_file: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    controller = VirtualController(SimConfig(speedup=20.0))
    yield from running_stack(controller, users_file, tmp_path_factory)


@pytest.fixture(scope="module")
def full_stack(users_file: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    """A stack whose simulator holds the largest file the protocol carries: 9999 steps of 100
    bytes (by default it refuses more than 4000 lines or 512 KiB in one upload, a guard of its
    own, above the 2000 steps of the manual's example)."""
    limits = UploadLimits(max_lines=MAX_STEP, max_bytes=MAX_STEP * LINE_MAX)
    controller = VirtualController(SimConfig(speedup=20.0), limits=limits)
    yield from running_stack(controller, users_file, tmp_path_factory)


def running_stack(
    controller: VirtualController, users_file: Path, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Stack]:
    """A :class:`Stack` in front of ``controller``, for a fixture to yield from."""
    sim = SimServer(controller).start()
    audit_path = tmp_path_factory.mktemp("audit") / "audit.jsonl"
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, name="web-stack", daemon=True)
    thread.start()

    async def start() -> tuple[LineServer, WebFace]:
        config = ServeConfig(
            lines=(
                LineConfig(
                    "cell1", sim.url, poll_interval=0.05, slow_interval=0.1, io_ports=(0, 1, 2, 3)
                ),
            ),
            faces={},
            audit_path=str(audit_path),
        )
        server = LineServer(config)
        await server.start()
        face = WebFace(server, {"listen": "127.0.0.1:0", "users": str(users_file)})
        await face.start()
        return server, face

    server, face = asyncio.run_coroutine_threadsafe(start(), loop).result(30)
    built = Stack(controller, sim, server, face, loop, audit_path)
    try:
        yield built
    finally:

        async def stop() -> None:
            await face.stop()
            await server.stop()

        asyncio.run_coroutine_threadsafe(stop(), loop).result(30)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(10)
        loop.close()
        sim.close()


@pytest.fixture(autouse=True)
def free_lease(request: pytest.FixtureRequest) -> Iterator[None]:
    """Each test starts with nobody holding the line (a lease lasts 30 s otherwise)."""
    yield
    if "stack" in request.fixturenames:
        stack: Stack = request.getfixturevalue("stack")
        holder = stack.line.lease.holder
        if holder is not None:
            stack.loop.call_soon_threadsafe(stack.line.lease.release, holder.who)


@pytest.fixture
def jog(stack: Stack) -> Iterator[Any]:
    """The jog page's WebSocket, olga signed in (talk to it with ``web_harness.ask``)."""
    from websockets.sync.client import connect

    with httpx.Client(base_url=stack.url, timeout=10) as http:
        token = login(http, "olga")
        cookie = "; ".join(f"{k}={v}" for k, v in http.cookies.items())
        url = stack.url.replace("http://", "ws://") + f"/line/cell1/jog/ws?csrf={token}"
        with connect(url, additional_headers={"Origin": stack.url, "Cookie": cookie}) as socket:
            yield socket


@pytest.fixture
def client(stack: Stack) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=stack.url, timeout=10.0) as http:
        yield http


@pytest.fixture(scope="module")
def chromium() -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api")
    if not Path(CHROMIUM).exists():
        pytest.skip("Debian's chromium is not installed (apt-get install chromium)")
    with sync_api.sync_playwright() as playwright:
        launched = playwright.chromium.launch(
            executable_path=CHROMIUM,
            args=[
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
            ],
        )
        try:
            yield launched
        finally:
            launched.close()


@pytest.fixture
def page(chromium: Any, stack: Stack) -> Iterator[Any]:
    """A browser tab of its own on the stack's dashboard (a fresh context: no cookies)."""
    context = chromium.new_context(base_url=stack.url)
    tab = context.new_page()
    tab.set_default_timeout(10_000)
    try:
        yield tab
    finally:
        context.close()
