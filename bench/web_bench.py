"""Web dashboard figures: change-to-DOM latency, 50 browsers' streams, keepalive loss to BG.

``python bench/web_bench.py`` starts a simulator on loopback, the line server in front of it with
the web face, and measures with Playwright driving Debian's Chromium:

1. latency from an input changing in the simulator to the page's DOM showing it (p50/p99);
2. 50 open browser pages' event streams on one line: how many of them show a change, and when;
3. time from the page's last jog keepalive to the simulator executing BG;
4. the jog page's position panel after a release: how long it still changed (the arm
   decelerating, the poll, the event stream), over runs;
5. an inch (one BD of 0.1) from the press to the page saying it moved, and how far the axis went;
6. the controller page's load time (its XY view reads the channels' KE parameters once a minute);
7. the program check of every file of the controller (FD, then FA of each).

Prints the figures (and writes ``bench/results/web.json``); nothing is asserted.
"""

from __future__ import annotations

import asyncio
import json
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

if __package__ in (None, ""):
    _root = Path(__file__).resolve().parent.parent
    sys.path[:0] = [str(_root), str(_root / "src")]

from tools.web_screenshots import CHROMIUM_ARGS

ROOT = Path(__file__).resolve().parent.parent


def _percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(share * len(ordered)))]


_WATCH_PANEL = """(el) => { window.panelChanges = []; new MutationObserver(() =>
    window.panelChanges.push(performance.now())).observe(el, {childList: true,
    characterData: true, subtree: true}); }"""


def _panel_after_release(page: Any, runs: int = 10) -> dict[str, Any]:
    """How long the jog page's position (axis 4, R) kept changing after the button's release."""
    page.goto("/line/cell1/jog")
    page.select_option("#jog-speed", "1")  # 1 %: half a second of jog stays inside the limits
    page.click("#jog-speed-set")
    page.locator("#jog-state").filter(has_text="Speed of channel 1").wait_for()
    cell = page.locator(
        'table.position[data-channel="1"] [data-key="cell1/ch1/angles"][data-axis="4"]'
    )
    cell.wait_for()
    after = []
    for run in range(runs):
        button = page.locator(f'.jog-btn[data-axis="4"][data-direction="{"+-"[run % 2]}"]')
        button.dispatch_event("pointerdown")
        page.locator("#jog-state").filter(has_text="Moving").wait_for()
        time.sleep(0.4)
        cell.evaluate(_WATCH_PANEL)
        released = page.evaluate("() => performance.now()")
        button.dispatch_event("pointerup")
        page.locator("#jog-state").filter(has_text="Stopped").wait_for()
        time.sleep(1.0)
        changes = page.evaluate("() => window.panelChanges")
        after.append(max([0.0, *[c - released for c in changes]]))
    return {"runs": runs, "p50": statistics.median(after), "max": max(after)}


def _inches(page: Any, controller: Any, sim: Any, runs: int = 10) -> dict[str, Any]:
    """Press to "Moved" for an inch of 0.1 on axis 4, and the axis's move each time."""
    page.goto("/line/cell1/jog")
    page.check('input[name="jog-step"][value="0.1"]')
    times, moves = [], []
    for _ in range(runs):
        while controller.model.channels[0].moving:
            time.sleep(0.01)
        with sim.lock:
            before = controller.model.channels[0].joints[3]
        page.evaluate("() => { document.getElementById('jog-state').textContent = ''; }")
        start_at = time.perf_counter()
        page.locator('.jog-btn[data-axis="4"][data-direction="+"]').dispatch_event("pointerdown")
        page.locator("#jog-state").filter(has_text="Moved axis 4").wait_for()
        times.append(time.perf_counter() - start_at)
        while controller.model.channels[0].moving:
            time.sleep(0.01)
        with sim.lock:
            moves.append(controller.model.channels[0].joints[3] - before)
    return {
        "runs": runs,
        "press_to_moved_ms_p50": 1000 * statistics.median(times),
        "press_to_moved_ms_max": 1000 * max(times),
        "moved_min": min(moves),
        "moved_max": max(moves),
    }


def _partial(results: dict[str, Any]) -> None:
    """The figures so far, on stderr: a run cut short still leaves them."""
    print(json.dumps(results), file=sys.stderr, flush=True)


def main(rounds: int = 60, pages: int = 50) -> dict[str, Any]:
    from playwright.sync_api import Error as PlaywrightError
    from playwright.sync_api import sync_playwright

    from robostar.serve.config import LineConfig, ServeConfig
    from robostar.serve.faces.web import WebFace
    from robostar.serve.line_server import LineServer
    from robostar.serve.users import Role, UserStore
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.listeners import SimServer

    results: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        users = Path(tmp) / "users.toml"
        UserStore(users).add("bench", Role.OPERATOR, "bench-password")
        controller = VirtualController(SimConfig(speedup=20.0))
        sim = SimServer(controller).start()
        loop = asyncio.new_event_loop()
        threading.Thread(target=loop.run_forever, daemon=True).start()

        async def start() -> tuple[LineServer, WebFace]:
            poll = 0.05
            server = LineServer(
                ServeConfig(
                    lines=(
                        LineConfig(
                            "cell1",
                            sim.url,
                            poll_interval=poll,
                            slow_interval=poll,
                            io_ports=(0, 1),
                        ),
                    ),
                    faces={},
                )
            )
            await server.start()
            face = WebFace(server, {"listen": "127.0.0.1:0", "users": str(users)})
            await face.start()
            return server, face

        server, face = asyncio.run_coroutine_threadsafe(start(), loop).result(30)

        def set_input(on: bool) -> None:
            with sim.lock:
                controller.model.set_input(1, 4, on)
            sim.wake()

        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS
            )
            page = browser.new_page(base_url=face.url)
            page.goto("/line/cell1")
            contact = page.locator('[data-key="cell1/io/in/1"] [data-contact="4"]')
            contact.wait_for()
            latencies = []
            for i in range(rounds):
                on = i % 2 == 0
                start_at = time.perf_counter()
                set_input(on)
                page.wait_for_function(
                    "([el, on]) => el.classList.contains(on ? 'on' : 'off')",
                    arg=[contact.element_handle(), on],
                    polling="raf",
                )
                latencies.append(time.perf_counter() - start_at)
            results["change_to_dom_ms"] = {
                "rounds": rounds,
                "p50": 1000 * statistics.median(latencies),
                "p99": 1000 * _percentile(latencies, 0.99),
                "poll_interval_ms": 50,
            }
            _partial(results)

            # one context each: 50 browsers, as 50 devices (one browser keeps six connections
            # to a server at most, and each page holds one for its event stream)
            contexts = [browser.new_context(base_url=face.url) for _ in range(pages)]
            opened = [context.new_page() for context in contexts]
            tabs, opening, failed = [], [], []
            for number, tab in enumerate(opened, 1):
                began = time.perf_counter()
                try:  # a page that does not open on a loaded machine is counted, not fatal
                    tab.goto("/line/cell1", timeout=60_000)
                    tab.wait_for_function(
                        "() => window.robostarStream && window.robostarStream.readyState === 1",
                        timeout=60_000,
                    )
                except PlaywrightError as exc:
                    failed.append(f"page {number}: {str(exc).splitlines()[0]}")
                    continue
                opening.append(time.perf_counter() - began)
                tabs.append(tab)
                print(f"page {number} of {pages}: {opening[-1]:.2f} s", file=sys.stderr, flush=True)
            set_input(False)
            time.sleep(0.5)
            start_at = time.perf_counter()
            set_input(True)
            shown = []
            for tab in tabs:
                tab.locator('[data-key="cell1/io/in/1"] [data-contact="4"].on').wait_for()
                shown.append(time.perf_counter() - start_at)
            results["streams"] = {
                "pages": pages,
                "pages_opened": len(tabs),
                "pages_not_opened": failed,
                "open_seconds_p50": statistics.median(opening) if opening else None,
                "open_seconds_max": max(opening) if opening else None,
                "pages_showing_the_change": len(shown),
                "seconds_until_the_last_page_shows_it": max(shown) if shown else None,
            }
            _partial(results)
            for context in contexts:
                context.close()

            page.goto("/login")
            page.fill("input[name=username]", "bench")
            page.fill("input[name=password]", "bench-password")
            page.click("form.login button[type=submit]")
            page.wait_for_url("**/")
            with sim.lock:
                controller.model.channels[0].servo = True
            gaps = []
            for _ in range(10):
                page.goto("/line/cell1/jog")
                before = controller.executions["BG"]
                page.locator('.jog-btn[data-axis="1"][data-direction="+"]').dispatch_event(
                    "pointerdown"
                )
                page.locator("#jog-state").filter(has_text="Moving").wait_for()
                time.sleep(0.3)
                stopped_at = time.perf_counter()
                page.evaluate("window.robostarJog.stopKeepalive()")
                while controller.executions["BG"] == before:
                    time.sleep(0.002)
                gaps.append(time.perf_counter() - stopped_at)
            results["keepalive_loss_to_bg_ms"] = {
                "runs": len(gaps),
                "p50": 1000 * statistics.median(gaps),
                "max": 1000 * max(gaps),
                "silence_limit_ms": 300,
            }
            results["panel_after_release_ms"] = _panel_after_release(page)
            with sim.lock:
                controller.model.channels[0].origin = True
            results["inch"] = _inches(page, controller, sim)
            loads = []
            for _ in range(10):
                start_at = time.perf_counter()
                page.goto("/line/cell1")
                page.locator("canvas.xyview").first.wait_for()
                loads.append(time.perf_counter() - start_at)
            results["controller_page_load_ms"] = {
                "runs": len(loads),
                "first": 1000 * loads[0],
                "p50_of_the_rest": 1000 * statistics.median(loads[1:]),
            }
            page.goto("/line/cell1/files")
            start_at = time.perf_counter()
            page.click("#check-form button[type=submit]")
            page.locator("table.check").wait_for()
            files = page.locator("table.check tr[class^=drift]").count()
            results["program_check"] = {
                "files": files,
                "seconds": time.perf_counter() - start_at,
            }
            browser.close()

        async def stop() -> None:
            await face.stop()
            await server.stop()

        asyncio.run_coroutine_threadsafe(stop(), loop).result(30)
        sim.close()
    out = ROOT / "bench" / "results" / "web.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=2))
    print(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
