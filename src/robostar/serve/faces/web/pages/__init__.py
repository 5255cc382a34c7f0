"""The dashboard's pages, one module each; each module's ``ROUTES`` are its Starlette routes.

Endpoints are plain functions that find what they share (the server, users, sessions, limits)
through :func:`robostar.serve.faces.web.deps.deps_of`: no page keeps state of its own.
"""

from __future__ import annotations

from robostar.serve.faces.web.pages import (
    audit,
    cell,
    controller,
    files,
    health,
    jog,
    lease,
    login,
    programs,
    variables,
)

__all__ = [
    "ALL",
    "audit",
    "cell",
    "controller",
    "files",
    "health",
    "jog",
    "lease",
    "login",
    "programs",
    "variables",
]

ALL = (cell, controller, files, programs, variables, jog, audit, health, lease, login)
"""Every page, in the order of the navigation."""
