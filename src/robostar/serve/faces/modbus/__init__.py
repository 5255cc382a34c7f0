"""The Modbus TCP face: the cell's PLC reads a line's status and runs commands by handshake.

``robostar serve --modbus NAME=HOST:PORT`` (or ``[modbus]`` in the config; docs/modbus.md)
serves each line on a port of its own with pymodbus's asyncio server: status bits, positions,
speed, job, alarms, I/O and globals from the line's model, each block with its age and quality
(``layout.py`` is the map, ``image.py`` fills it); commands by handshake in holding registers,
off unless enabled, each through the line's lease and audit log (``handshake.py``,
``runner.py``); ``server.py`` is the pymodbus glue, ``face.py`` the face.

The map and the settings need no pymodbus (``robostar serve modbus-map`` prints the map
without it); the face imports it when it is created.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from robostar.errors import UsageError
from robostar.serve.faces.modbus.settings import ModbusSettings, settings_from

if TYPE_CHECKING:
    from robostar.serve.faces.modbus.face import ModbusFace
    from robostar.serve.line_server import LineServer

__all__ = ["ModbusSettings", "create", "settings_from"]


def create(server: LineServer, options: Mapping[str, Any]) -> ModbusFace:
    """``options``: the ``[modbus]`` table (see :mod:`.settings`)."""
    settings = settings_from(options, set(server.lines))
    try:
        from robostar.serve.faces.modbus.face import ModbusFace
    except ModuleNotFoundError as exc:
        raise UsageError(
            f"the modbus face needs {exc.name!r}: pip install 'robostar[modbus]'"
        ) from exc
    return ModbusFace(server, settings)
