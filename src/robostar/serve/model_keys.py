"""Which model key answers which read: the line's reads feed the model, and a read that accepts
an older value (``max_age``) is answered from it."""

from __future__ import annotations

import math
from typing import Any

from robostar.commands.base import Command
from robostar.commands.control import ReadSpeed
from robostar.commands.files import ReadAlarmHistory
from robostar.commands.io import ReadInputs, ReadOutputs
from robostar.commands.job import ReadJobName, ReadJobStep
from robostar.commands.status import ReadAlarms, ReadInfo, ReadPosition, ReadStatus
from robostar.serve.model import ControllerModel
from robostar.types import PositionKind

__all__ = ["from_model", "keys_of", "model_key", "store"]

_STATUS_KEYS = tuple(f"ch{n}/status" for n in (1, 2, 3))
"""AA answers the status of the three channels at once."""


def model_key(command: Command[Any]) -> str | None:
    """The model key that answers ``command`` (a read), or None if the model cannot."""
    match command:
        case ReadInfo():
            return "info"
        case ReadAlarms():
            return "alarms"
        case ReadAlarmHistory():
            return "alarm_history"
        case ReadPosition(channel=ch, kind=PositionKind.XY):
            return f"ch{ch}/position"
        case ReadPosition(channel=ch, kind=PositionKind.ANGLE):
            return f"ch{ch}/angles"
        case ReadSpeed(channel=ch):
            return f"ch{ch}/speed"
        case ReadJobName(channel=ch):
            return f"ch{ch}/job"
        case ReadJobStep(channel=ch):
            return f"ch{ch}/step"
        case ReadInputs(port=port):
            return f"io/in/{port}"
        case ReadOutputs(port=port):
            return f"io/out/{port}"
    return None


def keys_of(command: Command[Any]) -> set[str]:
    """Every model key ``command``'s answer refreshes (AA: the three channels' status)."""
    if isinstance(command, ReadStatus):
        return set(_STATUS_KEYS)
    key = model_key(command)
    return set() if key is None else {key}


def from_model(
    model: ControllerModel, command: Command[Any], max_age: float
) -> tuple[Any, float] | None:
    """The model's answer to ``command`` and its time, if good and at most ``max_age`` old
    (and newer than the last state change); None when the model cannot answer."""
    if isinstance(command, ReadStatus):
        samples = [model.fresh(key, max_age) for key in _STATUS_KEYS]
        if all(s is not None for s in samples):
            good = [s for s in samples if s is not None]
            return tuple(s.value for s in good), min(s.at for s in good)
        return None
    key = model_key(command)
    if key is None:
        return None
    sample = model.fresh(key, max_age)
    return None if sample is None else (sample.value, sample.at)


def store(model: ControllerModel, command: Command[Any], result: Any, at: float) -> None:
    """Put ``command``'s answer into the model, stamped ``at`` (NaN: now)."""
    stamp = None if math.isnan(at) else at
    if isinstance(command, ReadStatus):
        for key, status in zip(_STATUS_KEYS, result, strict=False):
            model.set(key, status, stamp)
        return
    one = model_key(command)
    if one is not None:
        model.set(one, result, stamp)
