"""Checks a state snapshot (a JSON object read from ``--state``) before the model takes it.

A snapshot may have been edited by hand. Every value is checked for its type and range, and the
first bad one raises UsageError naming its key path and value, so that no edited file can give a
traceback, a NaN work timer or an alarm the controller does not know.
"""

from __future__ import annotations

import math
from typing import Any

from robostar.commands.control import MAX_SPEED
from robostar.commands.variables import MAX_POINT_INDEX, MAX_VALUE_INDEX
from robostar.errors import UsageError
from robostar.protocol.fields import FileName
from robostar.types import ArmForm

__all__ = ["MAX_WORK_TIMER", "check_snapshot"]

MAX_WORK_TIMER = 1e12
"""Model seconds a work timer may hold (some 30 000 years)."""
_MAX_AXES = 6
_MAX_NUMBER = 1e9
_MAX_INT = 2**31 - 1


class _Bad(Exception):
    def __init__(self, path: str, value: Any, what: str) -> None:
        shown = repr(value)
        if len(shown) > 60:
            shown = shown[:57] + "..."
        super().__init__(f"state snapshot: {path} = {shown} is not {what}")


def check_snapshot(data: dict[str, Any]) -> None:
    """Raise UsageError naming the first bad key and value of ``data``."""
    try:
        _check(data)
    except _Bad as bad:
        raise UsageError(str(bad)) from None


def _check(data: dict[str, Any]) -> None:
    _number(data, "work_timer", "work_timer", 0.0, MAX_WORK_TIMER)
    channels = _list(data, "channels", "channels")
    for c, channel in enumerate(channels):
        where = f"channels[{c}]"
        if not isinstance(channel, dict):
            raise _Bad(where, channel, "an object")
        _integer(channel, "speed", f"{where}.speed", 0, MAX_SPEED)
        job = _get(channel, "job", f"{where}.job")
        if job is not None:
            _name(job, f"{where}.job")
        for p, item in enumerate(_list(channel, "points", f"{where}.points")):
            _point(item, f"{where}.points[{p}]", MAX_POINT_INDEX)
        for f, stored in enumerate(_list(channel, "files", f"{where}.files")):
            _file(stored, f"{where}.files[{f}]")
    for kind, top, check in (("ints", MAX_VALUE_INDEX, _int_value), ("floats", 0, _float_value)):
        for i, pair in enumerate(_list(data, kind, kind)):
            path = f"{kind}[{i}]"
            if not isinstance(pair, list) or len(pair) != 2:
                raise _Bad(path, pair, "an [index, value] pair")
            _bounded_int(pair[0], f"{path}[0]", 0, top or MAX_VALUE_INDEX)
            check(pair[1], f"{path}[1]")
    for o, port in enumerate(_list(data, "outputs", "outputs")):
        if not isinstance(port, list) or len(port) > 16:
            raise _Bad(f"outputs[{o}]", port, "a list of at most 16 contacts")
        for n, contact in enumerate(port):
            if not isinstance(contact, bool) and contact not in (0, 1):
                raise _Bad(f"outputs[{o}][{n}]", contact, "true, false, 0 or 1")
    for a, entry in enumerate(_list(data, "alarm_history", "alarm_history")):
        _alarm(entry, f"alarm_history[{a}]")
    parameters = _get(data, "parameters", "parameters")
    if not isinstance(parameters, dict):
        raise _Bad("parameters", parameters, "an object")
    for key, text in parameters.items():
        if not key.isascii() or not key.isdigit() or len(key) > 4:
            raise _Bad(f"parameters[{key!r}]", key, "a parameter number")
        _text(text, f"parameters[{key!r}]")


def _get(data: dict[str, Any], key: str, path: str) -> Any:
    if key not in data:
        raise _Bad(path, "(missing)", "present")
    return data[key]


def _list(data: dict[str, Any], key: str, path: str) -> list[Any]:
    value = _get(data, key, path)
    if not isinstance(value, list):
        raise _Bad(path, value, "a list")
    return value


def _finite(value: Any, path: str, low: float, high: float) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or not low <= value <= high
    ):
        raise _Bad(path, value, f"a number from {low:g} to {high:g}")
    return float(value)


def _number(data: dict[str, Any], key: str, path: str, low: float, high: float) -> float:
    return _finite(_get(data, key, path), path, low, high)


def _bounded_int(value: Any, path: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise _Bad(path, value, f"a whole number from {low} to {high}")
    return value


def _integer(data: dict[str, Any], key: str, path: str, low: int, high: int) -> int:
    return _bounded_int(_get(data, key, path), path, low, high)


def _int_value(value: Any, path: str) -> None:
    _bounded_int(value, path, -_MAX_INT - 1, _MAX_INT)


def _float_value(value: Any, path: str) -> None:
    _finite(value, path, -_MAX_NUMBER, _MAX_NUMBER)


def _text(value: Any, path: str) -> str:
    if not isinstance(value, str) or not value.isascii() or len(value) > 250:
        raise _Bad(path, value, "ASCII text of at most 250 characters")
    return value


def _name(value: Any, path: str) -> FileName:
    _text(value, path)
    try:
        return FileName.parse(value)
    except UsageError as exc:
        raise _Bad(path, value, f"a file name ({exc})") from None


def _point(item: Any, path: str, top: int) -> None:
    if not isinstance(item, list) or len(item) != 4:
        raise _Bad(path, item, "an [index, axes, arm, used] point")
    index, axes, arm, used = item
    _bounded_int(index, f"{path}[0]", 0, top)
    if not isinstance(axes, list) or not 1 <= len(axes) <= _MAX_AXES:
        raise _Bad(f"{path}[1]", axes, f"a list of 1 to {_MAX_AXES} axis values")
    for n, value in enumerate(axes):
        _finite(value, f"{path}[1][{n}]", -_MAX_NUMBER, _MAX_NUMBER)
    _bounded_int(arm, f"{path}[2]", min(ArmForm), max(ArmForm))
    if not isinstance(used, bool):
        raise _Bad(f"{path}[3]", used, "true or false")


def _file(stored: Any, path: str) -> None:
    if not isinstance(stored, dict):
        raise _Bad(path, stored, "an object")
    name = _name(_get(stored, "name", f"{path}.name"), f"{path}.name")
    if name.is_job:
        _integer(stored, "number", f"{path}.number", 0, 9999)
        for n, line in enumerate(_list(stored, "lines", f"{path}.lines")):
            _text(line, f"{path}.lines[{n}]")
    else:
        for p, item in enumerate(_list(stored, "points", f"{path}.points")):
            _point(item, f"{path}.points[{p}]", 9999)


def _alarm(entry: Any, path: str) -> None:
    if not isinstance(entry, dict):
        raise _Bad(path, entry, "an object")
    _number(entry, "at", f"{path}.at", 0.0, MAX_WORK_TIMER)
    _integer(entry, "channel", f"{path}.channel", 1, 9)
    _integer(entry, "code", f"{path}.code", 0, 99999)
    _text(_get(entry, "text", f"{path}.text"), f"{path}.text")
    _text(entry.get("detail", ""), f"{path}.detail")
