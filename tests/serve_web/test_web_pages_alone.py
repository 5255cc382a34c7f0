"""Each page of the dashboard served on its own (``build_app(..., pages=(one,))``) and talked to
with httpx: a page needs nothing but the shared dependencies, and the routes of the pages left
out are not there."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from types import ModuleType

import httpx
import pytest

pytest.importorskip("starlette", reason="the web face needs the 'web' extra")

from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.web.app import WebSettings, build_app
from robostar.serve.faces.web.pages import audit, cell, controller, health, jog, login
from robostar.serve.users import UserStore


def _serve(
    pages: tuple[ModuleType, ...], test: Callable[[LineServer, httpx.AsyncClient], Awaitable[None]]
) -> None:
    config = ServeConfig(lines=(LineConfig("cell1", "sim://", poll_interval=0.05),), faces={})

    async def main() -> None:
        async with LineServer(config) as server:
            settings = WebSettings(users=UserStore(None), secret="s" * 32)
            app = build_app(server, settings, pages=pages)
            transport = httpx.ASGITransport(app=app)
            async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as http:
                await test(server, http)

    asyncio.run(main())


@pytest.mark.parametrize(
    ("page", "path", "shows"),
    [
        (cell, "/", "cell1"),
        (controller, "/line/cell1", "Emergency stop"),
        (jog, "/line/cell1/jog", "no enabling device"),
        (audit, "/audit", "Audit"),
        (health, "/health", "sim://"),
        (login, "/login", "password"),
    ],
)
def test_a_page_serves_alone(page: ModuleType, path: str, shows: str) -> None:
    async def test(server: LineServer, http: httpx.AsyncClient) -> None:
        answer = await http.get(path)
        assert answer.status_code == 200, answer.text
        assert shows in answer.text

    _serve((page,), test)


def test_a_page_left_out_is_not_served() -> None:
    async def test(server: LineServer, http: httpx.AsyncClient) -> None:
        assert (await http.get("/health")).status_code == 200
        assert (await http.get("/audit")).status_code == 404
        assert (await http.get("/line/cell1/jog")).status_code == 404

    _serve((health,), test)
