"""The MQTT face: the lines' live models in the plant's broker, and optional write-back.

``robostar serve --mqtt mqtt://HOST:PORT`` (or ``[mqtt]`` in the config) publishes every line's
model under ``<prefix>/<line>/...`` (docs/mqtt.md): retained JSON values with their time and
quality, reported by exception (a deadband on positions, a rate cap per line), a retained
``online`` per line with a last will, and ``<prefix>/_server/online``. While the broker is away,
changes wait in a bounded SQLite buffer and are replayed in order, marked historical. Commands
are off unless the configuration turns them on, per name.

Each line has its own MQTT connection (its own last will) and a pump task that reads the
line's model subscription, so a slow or silent broker never holds up a line's worker.

The parts: ``face`` (:class:`MqttFace`: a ``broker_link`` per line, the server's presence,
Sparkplug), ``settings`` (the ``[mqtt]`` section), ``connection`` (clients and the one
reconnect loop), ``publisher`` (reporter, buffer, replay: the values), ``requests`` (command
lanes and JSON answers), ``topics``, ``payload``, ``commands``; this module is the face's entry
point (:func:`create`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from robostar.serve.faces.mqtt.connection import QueueFullFilter
from robostar.serve.faces.mqtt.face import MqttFace
from robostar.serve.faces.mqtt.requests import BusyError
from robostar.serve.faces.mqtt.settings import MqttSettings, settings_from

if TYPE_CHECKING:
    from robostar.serve.line_server import LineServer

__all__ = ["BusyError", "MqttFace", "MqttSettings", "QueueFullFilter", "create", "settings_from"]


def create(server: LineServer, options: Mapping[str, Any]) -> MqttFace:
    """``options``: the ``[mqtt]`` section (docs/mqtt.md); ``url`` is required."""
    return MqttFace(server, settings_from(options))
