"""Alarm codes and the alarm log: the current alarms (AB) and the history (FH).

Two codes come from the manual (1153 "T/P Emergency", 1104 "Servo Not Redy", its spelling); the
others are the simulator's own, in the 9000s, listed in docs/simulator.md ("Alarm codes").
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

from robostar.types import Alarm, AlarmRecord

__all__ = ["ALL_CHANNELS", "EMERGENCIES", "AlarmCode", "AlarmEntry", "AlarmLog", "alarm_text"]

ALL_CHANNELS = 9
"""FH's channel number for an alarm of the whole controller."""
MAX_CURRENT = 10
MAX_HISTORY = 100
_PAGE = 10
_DETAIL_WIDTH = 16


class AlarmCode(enum.IntEnum):
    TP_EMERGENCY = 1153
    SERVO_NOT_READY = 1104
    HOST_EMERGENCY = 9001
    RUN_FAIL = 9002
    SOFT_LIMIT = 9003
    OUT_OF_REACH = 9004
    PATH_ERROR = 9005
    SYNTAX_ERROR = 9006
    JOB_NUMBER = 9007


_TEXTS = {
    AlarmCode.TP_EMERGENCY: "T/P Emergency",
    AlarmCode.SERVO_NOT_READY: "Servo Not Redy",
    AlarmCode.HOST_EMERGENCY: "Host Emergency",
    AlarmCode.RUN_FAIL: "Run Fail",
    AlarmCode.SOFT_LIMIT: "Soft Limit Over",
    AlarmCode.OUT_OF_REACH: "Out Of Reach",
    AlarmCode.PATH_ERROR: "Path Error",
    AlarmCode.SYNTAX_ERROR: "Syntax Error",
    AlarmCode.JOB_NUMBER: "Job Number Mismatch",
}

EMERGENCIES = frozenset((AlarmCode.TP_EMERGENCY, AlarmCode.HOST_EMERGENCY))
"""Alarms that turn the servo off as well as stopping motion."""


def alarm_text(code: int) -> str:
    """The pendant text of a code (20 characters at most)."""
    try:
        return _TEXTS[AlarmCode(code)]
    except ValueError:
        return f"Alarm {code}"


@dataclass(frozen=True, slots=True)
class AlarmEntry:
    """One alarm as it happened: when (work timer, model seconds), where, and why."""

    at: float
    channel: int
    code: int
    text: str
    detail: str = ""

    def to_json(self) -> dict[str, Any]:
        return {
            "at": self.at,
            "channel": self.channel,
            "code": self.code,
            "text": self.text,
            "detail": self.detail,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> AlarmEntry:
        return cls(
            float(data["at"]),
            int(data["channel"]),
            int(data["code"]),
            str(data["text"]),
            str(data.get("detail", "")),
        )


class AlarmLog:
    """Current alarms (cleared by CG) and the history, newest first (kept)."""

    def __init__(self) -> None:
        self.current: list[AlarmEntry] = []
        self.history: list[AlarmEntry] = []

    def raise_alarm(self, code: int, channel: int, at: float, detail: str = "") -> AlarmEntry:
        entry = AlarmEntry(at, channel, code, alarm_text(code), detail[:_DETAIL_WIDTH])
        if not any(a.code == code and a.channel == channel for a in self.current):
            self.current.append(entry)
            del self.current[:-MAX_CURRENT]
        self.history.insert(0, entry)
        del self.history[MAX_HISTORY:]
        return entry

    def clear(self) -> None:
        self.current.clear()

    def on_channel(self, channel: int) -> bool:
        """Does the channel have an alarm (its own, or one of the whole controller)?"""
        return any(a.channel in (channel, ALL_CHANNELS) for a in self.current)

    def alarms(self) -> tuple[Alarm, ...]:
        """The current alarms as AB lists them."""
        return tuple(Alarm(a.code, a.text) for a in self.current)

    def records(self) -> tuple[AlarmRecord, ...]:
        """The history as FH pages it: ten records a page, newest first."""
        out = []
        for i, entry in enumerate(self.history):
            total = int(entry.at)
            days, rest = divmod(total, 86400)
            hours, rest = divmod(rest, 3600)
            minutes, seconds = divmod(rest, 60)
            out.append(
                AlarmRecord(
                    page=i // _PAGE + 1,
                    index=i % _PAGE + 1,
                    day=days,
                    hours=hours,
                    minutes=minutes,
                    seconds=seconds,
                    channel=entry.channel,
                    text=entry.text,
                    detail=entry.detail,
                    code=entry.code,
                )
            )
        return tuple(out)
