"""Model values as the pages and the event stream show them: plain JSON, units, and quality."""

from __future__ import annotations

import time
from typing import Any

from robostar.serve.jsonable import jsonable
from robostar.serve.line import Line
from robostar.serve.model import Quality, Sample
from robostar.types import PositionKind, RobotType

__all__ = [
    "axis_unit",
    "card",
    "change_json",
    "channels",
    "clock",
    "detail",
    "health_row",
    "job_name",
    "robot_of",
    "sample_json",
]


def sample_json(sample: Sample | None) -> dict[str, Any]:
    """``{"value", "at", "quality"}``; a value never read is ``None`` with quality "line down"."""
    if sample is None:
        return {"value": None, "at": None, "quality": Quality.LINE_DOWN.value}
    return {"value": jsonable(sample.value), "at": sample.at, "quality": sample.quality.value}


def change_json(line: str, key: str, sample: Sample) -> dict[str, Any]:
    """A change as the event stream sends it, with the value's ``age`` in seconds now (the
    page adds the time since it arrived: no clock of the browser's is trusted)."""
    return {"line": line, "key": key, **sample_json(sample), "age": round(sample.age, 3)}


def axis_unit(kind: PositionKind, axis: int, robot: RobotType | None) -> str:
    """The unit of one axis of a position: mm, degrees or pulses.

    A SCARA's joints 1, 2 and 4 turn (degrees) and joint 3 slides (mm); in XY coordinates the
    4th value is the tool's rotation. Every axis of a cartesian robot slides."""
    if kind is PositionKind.PULSE:
        return "pulse"
    if axis == 4 and (kind is PositionKind.XY or robot is RobotType.SCARA):
        return "°"
    if kind is PositionKind.ANGLE and robot is RobotType.SCARA and axis in (1, 2):
        return "°"
    return "mm"


def job_name(value: object, empty: str = "—") -> str:
    """A job's name as the model's JSON holds it (``{"stem", "extension"}``) in words."""
    if isinstance(value, dict) and "stem" in value:
        return f"{value['stem']}.{value.get('extension', 'JOB')}"
    return empty if value is None or value == "" else str(value)


def clock(at: object) -> object:
    """An audit entry's ``time.time()`` as local date and time."""
    if isinstance(at, int | float):
        return time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(at))
    return at


def channels(line: Line) -> list[int]:
    """The channels to show and back up: the configured ones, else those the controller has
    (a channel AD reports NOT_DEFINED, with no axes, is none); all three until AD answered."""
    if line.config.channels or line.info is not None:
        return list(line.channels())
    return [1, 2, 3]


def robot_of(line: Line, channel: int) -> RobotType | None:
    info = line.model.get("info")
    if info is None:
        return None
    for entry in getattr(info.value, "channels", ()):
        if entry.channel == channel:
            robot: RobotType = entry.robot_type
            return robot
    return None


def card(line: Line) -> dict[str, Any]:
    """What an overview card shows of a line: online, and per channel the lamps and the job."""
    model = line.model
    names = getattr(line.config, "channels", {}) or {}
    shown = []
    for channel in channels(line):
        prefix = f"ch{channel}/"
        shown.append(
            {
                "number": channel,
                "name": names.get(channel, f"channel {channel}"),
                "status": sample_json(model.get(prefix + "status")),
                "job": sample_json(model.get(prefix + "job")),
                "step": sample_json(model.get(prefix + "step")),
                "speed": sample_json(model.get(prefix + "speed")),
            }
        )
    return {
        "name": line.name,
        "online": sample_json(model.get("online")),
        "alarms": sample_json(model.get("alarms")),
        "channels": shown,
    }


def detail(line: Line) -> dict[str, Any]:
    """The controller page beyond the card: positions with units, I/O, alarm history."""
    model = line.model
    axes = {}
    for channel in channels(line):
        robot = robot_of(line, channel)
        position = model.get(f"ch{channel}/position")
        values = list(position.value.axes) if position is not None else []
        axes[channel] = [
            {"axis": i + 1, "value": v, "unit": axis_unit(PositionKind.XY, i + 1, robot)}
            for i, v in enumerate(values)
        ]
    ports = []
    for port in range(5):
        inputs, outputs = model.get(f"io/in/{port}"), model.get(f"io/out/{port}")
        if inputs is None and outputs is None:
            continue
        ports.append({"port": port, "in": sample_json(inputs), "out": sample_json(outputs)})
    return {
        "info": sample_json(model.get("info")),
        "axes": axes,
        "ports": ports,
        "history": sample_json(model.get("alarm_history")),
    }


def health_row(line: Line) -> dict[str, Any]:
    health = line.health
    latency = None if health.latency is None else f"{1000 * health.latency:.1f} ms"
    age = health.poll_age
    return {
        "name": line.name,
        "url": line.config.url,
        "up": health.up,
        "last error": health.last_error or "—",
        "last exchange": latency or "—",
        "exchanges": health.exchanges,
        "errors": health.errors,
        "reconnects": health.reconnects,
        "last poll": "—" if age is None else f"{age:.1f} s ago",
        "lease": _lease_words(line),
    }


def _lease_words(line: Line) -> str:
    """Who holds ``line``'s control, for the health table (a one-shot lease said as such)."""
    state = line.control()
    if state.free:
        return "free"
    held = f"{state.holder} ({state.face})"
    return f"{held}, for one command" if state.once else held
