"""Which model key answers which read: the line's reads feed the model, and a read that accepts
an older value (``max_age``) is answered from it."""

from __future__ import annotations

import math
import time
from typing import Any

from robostar.commands.base import Command
from robostar.commands.control import ReadSpeed, SetSpeed
from robostar.commands.files import CopyFile, DeleteFile, ReadAlarmHistory, RenameFile, UploadFile
from robostar.commands.io import ReadInputs, ReadOutputs, SetOutput
from robostar.commands.job import ReadJobName, ReadJobStep
from robostar.commands.status import ReadAlarms, ReadInfo, ReadPosition, ReadStatus
from robostar.commands.variables import WriteGlobalFloat, WriteGlobalInt, WriteGlobalPoint
from robostar.serve.model import ControllerModel
from robostar.serve.status_witness import StatusWitness
from robostar.types import PositionKind

__all__ = ["ModelFeed", "changed_by", "keys_of", "model_key"]

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


def changed_by(command: Command[Any]) -> frozenset[str] | None:
    """The model keys a state change carried out may have changed beside the status and the
    positions (which the poller reads every cycle), or None: anything (the default for every
    command not named here, and for any refused or unknown outcome, which the caller handles).

    Only what the manual leaves no doubt about is narrowed: a speed change changes that
    channel's speed; a global variable write changes no polled value; an output may change the
    inputs it is wired to; a file written, copied, renamed or deleted may be a selected job."""
    match command:
        case SetSpeed(channel=ch):
            return frozenset((f"ch{ch}/speed",))
        case WriteGlobalInt() | WriteGlobalFloat() | WriteGlobalPoint():
            return frozenset()
        case SetOutput(port=port):
            return frozenset((f"io/out/{port}", f"io/in/{port}"))
        case UploadFile() | DeleteFile() | CopyFile() | RenameFile():
            return frozenset(f"ch{n}/{what}" for n in (1, 2, 3) for what in ("job", "step"))
    return None


class ModelFeed:
    """Puts reads' answers into a line's model, and answers reads from it.

    AA answers the status of all three channels; only the channels the controller has
    (``present``, from its AD answer) are model keys, so that the push faces show no channel it
    lacks. The others' statuses are kept aside, to answer AA from the model whole. Every status
    answer is also a witness (:class:`StatusWitness`): it confirms the positions of the
    channels that rest, so that they need not be read again."""

    def __init__(self, model: ControllerModel, rest_interval: float) -> None:
        self.model = model
        self.present: tuple[int, ...] = (1, 2, 3)
        self._absent: dict[str, Any] = {}
        self.witness = StatusWitness(model, rest_interval)

    def answer(self, command: Command[Any], max_age: float) -> tuple[Any, float] | None:
        """The model's answer to ``command`` and its time, if good and at most ``max_age`` old
        (and newer than the last state change); None when the model cannot answer."""
        if isinstance(command, ReadStatus):
            values: list[Any] = []
            times: list[float] = []
            for n, key in enumerate(_STATUS_KEYS, start=1):
                if n not in self.present:
                    if key not in self._absent:
                        return None
                    values.append(self._absent[key])
                    continue
                sample = self.model.fresh(key, max_age)
                if sample is None:
                    return None
                values.append(sample.value)
                times.append(sample.at)
            return tuple(values), min(times, default=0.0)
        one = model_key(command)
        if one is None:
            return None
        sample = self.model.fresh(one, max_age)
        return None if sample is None else (sample.value, sample.at)

    def store(self, command: Command[Any], result: Any, at: float) -> None:
        """Put ``command``'s answer into the model, stamped ``at`` (NaN: now)."""
        stamp = time.time() if math.isnan(at) else at
        if isinstance(command, ReadStatus):
            present: dict[int, Any] = {}
            for n, (key, status) in enumerate(zip(_STATUS_KEYS, result, strict=False), start=1):
                if n in self.present:
                    self.model.set(key, status, stamp)
                    present[n] = status
                else:
                    self._absent[key] = status
            self.witness.status(present, stamp)
            return
        one = model_key(command)
        if one is not None:
            self.model.set(one, result, stamp)
            self.witness.read(one, stamp)
