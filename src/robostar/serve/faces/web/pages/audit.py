"""The audit page: the last entries of the audit log, newest first."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any

from starlette.requests import Request
from starlette.responses import Response
from starlette.routing import BaseRoute, Route

from robostar.serve.faces.web.deps import deps_of

__all__ = ["ROUTES", "audit_tail"]

SHOWN = 200
"""Entries on the page."""


async def audit(request: Request) -> Response:
    deps = deps_of(request)
    return deps.page(request, "audit.html", entries=audit_tail(deps.settings.audit_path, SHOWN))


def audit_tail(path: str | None, count: int) -> list[dict[str, Any]]:
    """The last ``count`` audit entries, newest first (the file is JSON lines)."""
    if path is None or not Path(path).exists():
        return []
    with open(path, "rb") as handle:
        handle.seek(0, 2)
        size = handle.tell()
        handle.seek(max(0, size - 256 * 1024))
        tail = handle.read().decode("utf-8", "replace").splitlines()
    entries = []
    for text in reversed(tail[-count:]):
        with contextlib.suppress(ValueError):
            entry = json.loads(text)
            if isinstance(entry, dict):
                entries.append(entry)
    return entries


ROUTES: list[BaseRoute] = [Route("/audit", audit)]
