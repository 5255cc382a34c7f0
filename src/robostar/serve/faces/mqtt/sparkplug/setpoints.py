"""Writable metrics: a DCMD that writes a setpoint's metric (``ch1/speed``, ``io/out/0/3``) is
the face's command for it, with the metric's value as its parameter (pure logic).

A SCADA writes a tag it reads: the speed override and the outputs are the values an operator
sets. The command is then run as a ``cmd/<name>`` would be: only when the face's commands are
enabled and its name (``speed``, ``output``) is allowed, through the lease and the audit log.
"""

from __future__ import annotations

import re
from typing import Any

from robostar.errors import UsageError
from robostar.serve.faces.mqtt.sparkplug import sparkplug_b_pb2 as pb

__all__ = ["SETPOINTS", "setpoint_command"]

_SPEED = re.compile(r"ch(\d{1,2})/speed")
_OUTPUT = re.compile(r"io/out/(\d{1,2})/(\d{1,2})")
SETPOINTS = ("chN/speed", "io/out/N/C")
"""The writable metrics' shapes (for an error's words)."""


def _value(metric: pb.Payload.Metric) -> Any:
    kind = metric.WhichOneof("value")
    return None if kind is None else getattr(metric, kind)


def _whole(metric: pb.Payload.Metric, name: str) -> int:
    value = _value(metric)
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise UsageError(f"{name}: expected a whole number, not {value!r}")
    return value


def _switch(metric: pb.Payload.Metric, name: str) -> bool:
    value = _value(metric)
    if not isinstance(value, bool):
        raise UsageError(f"{name}: expected a Boolean, not {value!r}")
    return value


def setpoint_command(name: str, metric: pb.Payload.Metric) -> tuple[str, dict[str, Any]] | None:
    """The command a write of metric ``name`` asks for, and its parameters; None when ``name``
    is no setpoint. UsageError when the value is not of the metric's kind."""
    if match := _SPEED.fullmatch(name):
        return "speed", {"channel": int(match[1]), "value": _whole(metric, name)}
    if match := _OUTPUT.fullmatch(name):
        on = _switch(metric, name)
        return "output", {"port": int(match[1]), "contact": int(match[2]), "on": on}
    return None
