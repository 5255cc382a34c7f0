"""The cell page (every line at a glance) and the live event stream every page listens to."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response, StreamingResponse
from starlette.routing import BaseRoute, Route

from robostar.serve.faces.web.deps import deps_of
from robostar.serve.faces.web.views import card, change_json, sample_json
from robostar.serve.line import Line

__all__ = ["EVENT_KEEPALIVE", "ROUTES"]

_STATIC = Path(__file__).parent.parent / "static"
EVENT_KEEPALIVE = 15.0
"""Seconds between SSE comments on a quiet stream, so proxies keep it open."""


async def overview(request: Request) -> Response:
    deps = deps_of(request)
    cards = [card(line) for line in deps.server.lines.values()]
    return deps.page(request, "overview.html", cards=cards)


async def events(request: Request) -> Response:
    deps = deps_of(request)
    wanted = request.query_params.get("line")
    lines = [line for line in deps.server.lines.values() if wanted in (None, line.name)]
    return StreamingResponse(
        _event_stream(request, lines),
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


async def _event_stream(request: Request, lines: list[Line]) -> AsyncIterator[str]:
    """One browser's stream: a first snapshot, then every change of its lines' models."""
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
        while True:
            try:
                text = await asyncio.wait_for(merged.get(), EVENT_KEEPALIVE)
            except TimeoutError:
                if await request.is_disconnected():
                    return
                yield ": keepalive\n\n"
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
