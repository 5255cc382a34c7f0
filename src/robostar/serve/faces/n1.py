"""The N1 face: the unchanged N1 host protocol (controller role) on a TCP port per line.

See :mod:`robostar.serve.n1serve` for how sessions, the queue and the lease meet.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from robostar.errors import UsageError
from robostar.serve.n1serve import N1Face
from robostar.serving import parse_listen

if TYPE_CHECKING:
    from robostar.serve.server import LineServer

__all__ = ["N1Face", "create"]


def create(server: LineServer, options: Mapping[str, Any]) -> N1Face:
    """``options``: ``{"lines": {NAME: "HOST:PORT"}, "allow_remote": bool}``."""
    lines = options.get("lines", {})
    if not isinstance(lines, Mapping) or not lines:
        raise UsageError('n1.lines: expected NAME = "HOST:PORT" for at least one line')
    listens: dict[str, tuple[str, int]] = {}
    for name, listen in lines.items():
        if name not in server.lines:
            raise UsageError(f"n1.lines.{name}: no such line (lines: {', '.join(server.lines)})")
        listens[name] = parse_listen(str(listen))
    return N1Face(server, listens, bool(options.get("allow_remote", False)))
