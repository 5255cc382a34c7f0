"""The cell page (every line at a glance) and the live event stream every page listens to."""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response, StreamingResponse
from starlette.routing import BaseRoute, Route

from robostar.serve.faces.web.deps import deps_of
from robostar.serve.faces.web.pages.lease import lease_row
from robostar.serve.faces.web.views import card, change_json, sample_json
from robostar.serve.line import Line

__all__ = ["ROUTES", "STATUS_EVERY"]

_STATIC = Path(__file__).parent.parent / "static"
STATUS_EVERY = 1.0
"""Seconds between the stream's status events (ages, leases); they keep proxies open too."""


async def overview(request: Request) -> Response:
    deps = deps_of(request)
    cards = [card(line) for line in deps.server.lines.values()]
    return deps.page(request, "overview.html", cards=cards)


async def events(request: Request) -> Response:
    deps = deps_of(request)
    wanted = request.query_params.get("line")
    lines = [line for line in deps.server.lines.values() if wanted in (None, line.name)]
    account = deps.account(request)

    def status() -> dict[str, Any]:
        return {
            "key": "status",  # every event's data names what it carries
            "ages": {
                f"{line.name}/{key}": round(sample.age, 3)
                for line in lines
                for key, sample in line.model.snapshot().items()
                if key.endswith(("/position", "/angles"))
            },
            "leases": [lease_row(line, account) for line in deps.server.lines.values()],
        }

    return StreamingResponse(
        _event_stream(request, lines, status),
        media_type="text/event-stream",
        headers={"cache-control": "no-store", "x-accel-buffering": "no"},
    )


async def favicon(request: Request) -> Response:
    """Browsers ask for /favicon.ico whatever the page says: the same icon, not a 404."""
    return FileResponse(_STATIC / "favicon.svg", media_type="image/svg+xml")


async def snapshot(request: Request) -> Response:
    line = deps_of(request).line_of(request)
    values = {key: sample_json(sample) for key, sample in line.model.snapshot().items()}
    return JSONResponse({"line": line.name, "values": values})


async def ages(request: Request) -> Response:
    """How old each of the line's values is now (seconds since it was last read, changed or
    not): the event stream sends changes only, and a value at rest is read again all the same."""
    line = deps_of(request).line_of(request)
    found = {key: round(sample.age, 3) for key, sample in line.model.snapshot().items()}
    return JSONResponse({"line": line.name, "ages": found})


async def _event_stream(
    request: Request, lines: list[Line], status: Callable[[], dict[str, Any]]
) -> AsyncIterator[str]:
    """One browser's stream: a first snapshot, then every change of its lines' models, and
    every :data:`STATUS_EVERY` s a status event: the positions' ages (a value at rest is read
    again without a change) and who holds each line's lease. On the one connection: a page
    polls nothing (a browser opens six connections to a server at most)."""
    subscriptions = [line.model.subscribe(maxsize=500) for line in lines]
    merged = asyncio.Queue[str](maxsize=1000)

    async def pump(line: Line, subscription: Any) -> None:
        async for change in subscription:
            text = json.dumps(change_json(line.name, change.key, change.sample))
            await merged.put(text)

    pairs = zip(lines, subscriptions, strict=True)
    tasks = [asyncio.create_task(pump(line, sub)) for line, sub in pairs]
    try:
        for line in lines:
            for key, sample in line.model.snapshot().items():
                yield f"event: change\ndata: {json.dumps(change_json(line.name, key, sample))}\n\n"
        next_status = 0.0
        while True:
            now = time.monotonic()
            if now >= next_status:
                if await request.is_disconnected():
                    return
                next_status = now + STATUS_EVERY
                yield f"event: status\ndata: {json.dumps(status())}\n\n"
            try:
                text = await asyncio.wait_for(merged.get(), next_status - now)
            except TimeoutError:
                continue
            yield f"event: change\ndata: {text}\n\n"
    finally:
        for task in tasks:
            task.cancel()
        for subscription in subscriptions:
            subscription.close()


ROUTES: list[BaseRoute] = [
    Route("/", overview),
    Route("/events", events),
    Route("/favicon.ico", favicon),
    Route("/line/{line}/snapshot", snapshot),
    Route("/line/{line}/ages", ages),
]
