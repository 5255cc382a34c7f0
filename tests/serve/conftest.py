"""Helpers of the line server tests: a server in front of the in-process simulator."""

from __future__ import annotations

from robostar.serve import LineConfig, LineServer, ServeConfig


def sim_server(*names: str, poll_interval: float = 0.05, **kwargs: object) -> LineServer:
    """A server with one ``sim://`` line per name (default: ``cell1``)."""
    lines = tuple(LineConfig(n, "sim://", poll_interval=poll_interval) for n in names or ("cell1",))
    return LineServer(ServeConfig(lines=lines, faces={}, **kwargs))  # type: ignore[arg-type]
