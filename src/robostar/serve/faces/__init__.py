"""The faces of the line server: each a module with ``create(server, options) -> Face``."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Protocol

from robostar.errors import UsageError

if TYPE_CHECKING:
    from robostar.serve.line_server import LineServer

__all__ = ["FACES", "Face", "create_face"]

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


def create_face(name: str, server: LineServer, options: Mapping[str, Any]) -> Face:
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
