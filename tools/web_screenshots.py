"""Screenshots of every dashboard page for docs/web.md (``make screenshots``).

Starts a simulator, the line server and the web face on loopback, signs in as an engineer made
for the occasion in a temporary users file, homes channel 1 and runs its demo job (so the XY view
has a trail), writes a job through the dashboard and changes it "at the pendant" (so the
versions page has a diff), and saves one PNG per page with Playwright driving Debian's Chromium.
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
    "controller": "/line/cell1?points=DEMO.PNT&pch=1",
    "files": "/line/cell1/files?channel=1",
    "file": "/line/cell1/files/1/DEMO.PNT",
    "versions": "/line/cell1/files/1/PICK.JOB/versions?a=-1&b=current",
    "jog": "/line/cell1/jog",
    "variables": "/line/cell1/variables?kind=float&count=10",
    "audit": "/audit",
    "health": "/health",
}


def main(out: str = "docs/img", chromium: str = "/usr/bin/chromium") -> None:
    from playwright.sync_api import sync_playwright

    from robostar.commands.control import StartJob
    from robostar.commands.job import SelectJob
    from robostar.commands.motion import Home
    from robostar.protocol.fields import FileName
    from robostar.serve.config import LineConfig, ServeConfig
    from robostar.serve.faces.web import WebFace
    from robostar.serve.lease import Who
    from robostar.serve.line_server import LineServer
    from robostar.serve.users import Role, UserStore
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.filesystem import StoredJob
    from robostar.sim.listeners import SimServer

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        users = Path(tmp) / "users.toml"
        UserStore(users).add("engineer", Role.ENGINEER, "screenshot-pass")
        controller = VirtualController(SimConfig(speedup=20.0))
        sim = SimServer(controller).start()
        with sim.lock:
            controller.model.channels[0].servo = True
            controller.model.set_input(0, 2, True)
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

        async def run_demo() -> None:
            line, who = server.lines["cell1"], Who("screenshots", "cli")
            await line.execute(Home(1), who=who, implicit_lease=True)
            await asyncio.sleep(1.0)
            await line.execute(SelectJob(1, "DEMO.JOB"), who=who)
            line.lease.release(who)

        async def start_job() -> None:  # while the controller page looks: a trail
            line, who = server.lines["cell1"], Who("engineer", "web")  # who holds it now
            await line.execute(StartJob(1), who=who, implicit_lease=True)

        asyncio.run_coroutine_threadsafe(run_demo(), loop).result(30)
        with sim.lock:  # an alarm on channel 2, for the alarm list (channel 1 runs on)
            controller.model.raise_alarm(1153, 2)
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
            page = browser.new_page(base_url=face.url, viewport={"width": 1280, "height": 860})
            page.goto("/login")
            page.fill("input[name=username]", "engineer")
            page.fill("input[name=password]", "screenshot-pass")
            page.click("form.login button[type=submit]")
            page.wait_for_url("**/")
            csrf = page.locator('meta[name="csrf-token"]').get_attribute("content")
            written = page.request.post(
                f"{face.url}/line/cell1/files/upload/confirm",
                form={
                    "csrf_token": str(csrf),
                    "channel": "1",
                    "name": "PICK.JOB",
                    "job_number": "7",
                    "content": "MAIN\nMOVJ P0001\nDELAY 50\nMOVJ P0002\nEOP\n",
                    "confirmed": "yes",
                },
                max_redirects=0,
            )
            assert written.status == 303, written.text()
            pendant = StoredJob(
                FileName.parse("PICK.JOB"),
                7,
                ["MAIN", "MOVJ P0001", "DELAY 80", "MOVJ P0003", "EOP"],
            )
            with sim.lock:  # an edit at the pendant, not through the server
                controller.model.channels[0].files.put(pendant)
            for name, path in PAGES.items():
                page.goto(path)
                if name == "controller":
                    asyncio.run_coroutine_threadsafe(start_job(), loop).result(30)
                time.sleep(2.0 if name in ("controller", "jog") else 0.5)  # a trail, a position
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
