"""Screenshots of every dashboard page for docs/web.md (``make screenshots``).

Starts a simulator, the line server and the web face on loopback, signs in as an operator made
for the occasion in a temporary users file, and saves one PNG per page with Playwright driving
Debian's Chromium.
"""

from __future__ import annotations

import asyncio
import sys
import tempfile
import threading
import time
from pathlib import Path

CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
PAGES = {
    "overview": "/",
    "controller": "/line/cell1",
    "files": "/line/cell1/files?channel=1",
    "file": "/line/cell1/files/1/DEMO.JOB",
    "jog": "/line/cell1/jog",
    "variables": "/line/cell1/variables?kind=float&count=10",
    "audit": "/audit",
    "health": "/health",
}


def main(out: str = "docs/img", chromium: str = "/usr/bin/chromium") -> None:
    from playwright.sync_api import sync_playwright

    from robostar.serve.config import LineConfig, ServeConfig
    from robostar.serve.faces.web import WebFace
    from robostar.serve.line_server import LineServer
    from robostar.serve.users import Role, UserStore
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.listeners import SimServer

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        users = Path(tmp) / "users.toml"
        UserStore(users).add("operator", Role.OPERATOR, "screenshot-pass")
        controller = VirtualController(SimConfig(speedup=20.0))
        sim = SimServer(controller).start()
        with sim.lock:
            controller.model.channels[0].servo = True
            controller.model.set_input(0, 2, True)
            controller.model.raise_alarm(1153)
        loop = asyncio.new_event_loop()
        threading.Thread(target=loop.run_forever, daemon=True).start()

        async def start() -> tuple[LineServer, WebFace]:
            config = ServeConfig(
                lines=(LineConfig("cell1", sim.url, poll_interval=0.1),),
                faces={},
                audit_path=str(Path(tmp) / "audit.jsonl"),
            )
            server = LineServer(config)
            await server.start()
            face = WebFace(server, {"listen": "127.0.0.1:0", "users": str(users)})
            await face.start()
            return server, face

        server, face = asyncio.run_coroutine_threadsafe(start(), loop).result(30)
        time.sleep(1.0)  # the poller fills the model
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
            page = browser.new_page(base_url=face.url, viewport={"width": 1280, "height": 860})
            page.goto("/login")
            page.fill("input[name=username]", "operator")
            page.fill("input[name=password]", "screenshot-pass")
            page.click("form.login button[type=submit]")
            page.wait_for_url("**/")
            for name, path in PAGES.items():
                page.goto(path)
                time.sleep(0.5)
                page.screenshot(path=str(folder / f"web-{name}.png"), full_page=True)
                print(folder / f"web-{name}.png")
            browser.close()

        async def stop() -> None:
            await face.stop()
            await server.stop()

        asyncio.run_coroutine_threadsafe(stop(), loop).result(30)
        sim.close()


if __name__ == "__main__":
    main(*sys.argv[1:])
