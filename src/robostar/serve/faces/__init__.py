"""The faces of the line server: each a module with ``create(server, options) -> Face``.

The server hands each face what it needs (:class:`FaceServer`: its lines, its faces, its
configuration); this registry does not import the server, which imports it."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any, Protocol

from robostar.errors import UsageError
from robostar.serve.config import ServeConfig
from robostar.serve.line import Line

__all__ = ["FACES", "Face", "FaceServer", "create_face"]

FACES: dict[str, str] = {
    "n1": "robostar.serve.faces.n1",
    "api": "robostar.serve.faces.api",
    "mqtt": "robostar.serve.faces.mqtt",
    "opcua": "robostar.serve.faces.opcua",
    "web": "robostar.serve.faces.web",
    "metrics": "robostar.serve.faces.metrics",
    "modbus": "robostar.serve.faces.modbus",
}


class Face(Protocol):
    """A way in to the line server (a protocol, a port): started after the lines, stopped before."""

    async def start(self) -> None: ...

    async def stop(self) -> None: ...


class FaceServer(Protocol):
    """What a face is handed: the server's lines, its other faces, its configuration
    (:class:`~robostar.serve.line_server.LineServer` is one)."""

    @property
    def lines(self) -> Mapping[str, Line]: ...

    @property
    def faces(self) -> Mapping[str, Face]: ...

    @property
    def config(self) -> ServeConfig: ...


def create_face(name: str, server: FaceServer, options: Mapping[str, Any]) -> Face:
    """Import a face's module and create it; UsageError if unknown, missing or lacking an extra."""
    module_name = FACES.get(name)
    if module_name is None:
        raise UsageError(f"unknown face {name!r} (known: {', '.join(FACES)})")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name == module_name:
            raise UsageError(f"the {name} face is not available in this build") from exc
        raise UsageError(
            f"the {name} face needs {exc.name!r}: pip install 'robostar[serve]'"
        ) from exc
    face: Face = module.create(server, options)
    return face
