"""The simulator's configuration: controller identity, channels, timing, from code, a URL or TOML.

Every field has a plausible default, so ``SimConfig()`` is a two-channel N1 (a 4-axis SCARA and a
2-axis cartesian robot). ``from_query`` reads a ``sim://`` URL's query, ``from_file`` a TOML file;
both are documented in docs/simulator.md ("Configuration").
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from typing import Any

from robostar.commands.identity import simulator_version
from robostar.errors import UsageError
from robostar.types import RobotType

__all__ = ["ChannelConfig", "SimConfig", "robot_type_from_text"]

_ROBOT_NAMES = {
    "xy": RobotType.XY,
    "cartesian": RobotType.XY,
    "scara": RobotType.SCARA,
    "transfer": RobotType.TRANSFER,
    "cylinder": RobotType.CYLINDER,
    "bgt": RobotType.BACKGROUND_TASK,
    "background": RobotType.BACKGROUND_TASK,
}

# Per-axis defaults (axis 1..6) by robot kind: soft limits, Mv, pulses per degree or mm.
_SCARA_LIMITS = ((-120.0, 120.0), (-145.0, 145.0), (0.0, 200.0), (-360.0, 360.0))
_SCARA_SPEED = (360.0, 360.0, 1000.0, 720.0)
_SCARA_PULSES = (1000.0, 1000.0, 500.0, 500.0)
_LINEAR_LIMITS = (0.0, 600.0)
_LINEAR_SPEED = 1000.0
_LINEAR_PULSES = 100.0
_EXTRA_LIMITS = (-360.0, 360.0)
_EXTRA_SPEED = 360.0
_EXTRA_PULSES = 100.0
_DEFAULT_MODELS = {
    RobotType.XY: "XY",
    RobotType.SCARA: "RSA60A",
    RobotType.TRANSFER: "TRANSFER",
    RobotType.CYLINDER: "CYLINDER",
    RobotType.BACKGROUND_TASK: "BGT",
    RobotType.NOT_DEFINED: "",
}


def robot_type_from_text(text: str) -> RobotType:
    """``scara``, ``xy`` (or ``cartesian``), ``transfer``, ``cylinder``, ``bgt``, or a type code."""
    key = text.strip().lower()
    if key in _ROBOT_NAMES:
        return _ROBOT_NAMES[key]
    if key.isdigit() and int(key) in {int(t) for t in RobotType}:
        return RobotType(int(key))
    names = ", ".join(sorted(_ROBOT_NAMES))
    raise UsageError(f"robot: {text!r} is not a robot type ({names})")


def _default_axis(robot: RobotType, axis: int) -> tuple[tuple[float, float], float, float]:
    """Limits, max speed and pulses per unit of one axis (1-based) of a robot kind."""
    if robot is RobotType.SCARA and axis <= 4:
        return _SCARA_LIMITS[axis - 1], _SCARA_SPEED[axis - 1], _SCARA_PULSES[axis - 1]
    if robot is not RobotType.SCARA and axis <= 3:
        return _LINEAR_LIMITS, _LINEAR_SPEED, _LINEAR_PULSES
    return _EXTRA_LIMITS, _EXTRA_SPEED, _EXTRA_PULSES


def _floats(name: str, values: Any, count: int) -> tuple[float, ...]:
    if isinstance(values, str | bytes) or not isinstance(values, Sequence):
        raise UsageError(f"{name}: must be a list of {count} numbers")
    if len(values) != count:
        raise UsageError(f"{name}: needs {count} values (one per axis), got {len(values)}")
    out = []
    for value in values:
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise UsageError(f"{name}: {value!r} is not a finite number")
        out.append(float(value))
    return tuple(out)


@dataclass(frozen=True)
class ChannelConfig:
    """One robot channel. Fields left empty take the robot kind's defaults.

    ``limits`` are the soft limits per axis (degrees, or mm on a linear axis); ``max_speed`` is
    each axis's Mv (deg/s or mm/s); ``pulses_per_unit`` converts to encoder pulses. For a SCARA,
    axes 1 and 2 are the arm joints (``link_lengths`` in mm), 3 is Z (mm) and 4 is W (degrees).
    ``linear_speed`` caps the tool's speed (mm/s) on straight lines and arcs.
    """

    robot: RobotType = RobotType.SCARA
    axes: int = 4
    model: str = ""
    limits: tuple[tuple[float, float], ...] = ()
    link_lengths: tuple[float, float] = (350.0, 250.0)
    max_speed: tuple[float, ...] = ()
    pulses_per_unit: tuple[float, ...] = ()
    linear_speed: float = 2000.0

    def __post_init__(self) -> None:
        robot = self.robot
        if not isinstance(robot, RobotType):
            robot = robot_type_from_text(str(robot))
            object.__setattr__(self, "robot", robot)
        if isinstance(self.axes, bool) or not isinstance(self.axes, int) or not 1 <= self.axes <= 6:
            raise UsageError(f"axes: {self.axes!r} is not 1..6")
        if robot is RobotType.SCARA and self.axes < 2:
            raise UsageError("axes: a SCARA needs at least 2 axes (the two arm joints)")
        defaults = [_default_axis(robot, axis) for axis in range(1, self.axes + 1)]
        if not self.model:
            object.__setattr__(self, "model", _DEFAULT_MODELS[robot])
        if len(self.model) > 10:
            raise UsageError(f"model: {self.model!r} is longer than 10 characters")
        limits = self.limits or tuple(d[0] for d in defaults)
        if len(limits) != self.axes:
            raise UsageError(f"limits: needs {self.axes} (low, high) pairs, got {len(limits)}")
        checked = []
        for i, pair in enumerate(limits):
            lo, hi = _floats(f"limits[{i}]", pair, 2)
            if lo >= hi:
                raise UsageError(f"limits[{i}]: low {lo} is not below high {hi}")
            checked.append((lo, hi))
        object.__setattr__(self, "limits", tuple(checked))
        speeds = _floats("max_speed", self.max_speed or [d[1] for d in defaults], self.axes)
        if any(v <= 0 for v in speeds):
            raise UsageError("max_speed: every axis needs a speed above 0")
        object.__setattr__(self, "max_speed", speeds)
        pulses = _floats(
            "pulses_per_unit", self.pulses_per_unit or [d[2] for d in defaults], self.axes
        )
        if any(v <= 0 for v in pulses):
            raise UsageError("pulses_per_unit: every axis needs a value above 0")
        object.__setattr__(self, "pulses_per_unit", pulses)
        lengths = _floats("link_lengths", self.link_lengths, 2)
        if any(v <= 0 for v in lengths):
            raise UsageError("link_lengths: both links need a length above 0")
        object.__setattr__(self, "link_lengths", lengths)
        (linear,) = _floats("linear_speed", [self.linear_speed], 1)
        if linear <= 0:
            raise UsageError("linear_speed: must be above 0")
        object.__setattr__(self, "linear_speed", linear)

    @property
    def can_move(self) -> bool:
        """A background task channel runs jobs but has no robot."""
        return self.robot not in (RobotType.BACKGROUND_TASK, RobotType.NOT_DEFINED)


def _default_channels() -> tuple[ChannelConfig, ...]:
    return (ChannelConfig(RobotType.SCARA, 4), ChannelConfig(RobotType.XY, 2))


@dataclass(frozen=True)
class SimConfig:
    """The whole virtual controller.

    ``speedup``: model time runs this many times faster than real time. ``ack_timeout``: real
    seconds before the link resends an unacknowledged answer. ``io_boards``: input and output
    boards, 0-2 each (port 0 is the main board's; each board adds two ports).

    ``version`` is the configured text; AD answers :attr:`served_version`, which always ends in
    ``-SIM`` (robostar.commands.identity), so that a simulator renamed to look like a robot is
    still known as a simulator over tcp:// or a pseudo-terminal.
    """

    name: str = "N1-SIM"
    version: str = "N1RO 03.02.05-SIM"
    channels: tuple[ChannelConfig, ...] = field(default_factory=_default_channels)
    auto_servo_on: bool = True
    io_boards: tuple[int, int] = (1, 1)
    speedup: float = 1.0
    ack_timeout: float = 2.0
    seed: int | None = None
    dialect: str = "manual"
    """How the answers are written (robostar.sim.dialects: manual, capacity, left-aligned,
    padded)."""
    journal: str | PathLike[str] | None = None
    """A JSONL file the controller appends every state change it carries out to
    (robostar.sim.journal); None keeps no journal."""

    def __post_init__(self) -> None:
        if len(self.name) > 15:
            raise UsageError(f"name: {self.name!r} is longer than 15 characters")
        if len(self.version) > 20:
            raise UsageError(f"version: {self.version!r} is longer than 20 characters")
        channels = tuple(self.channels)
        if not 1 <= len(channels) <= 3:
            raise UsageError(f"channels: an N1 has 1 to 3 channels, not {len(channels)}")
        if not all(isinstance(c, ChannelConfig) for c in channels):
            raise UsageError("channels: every channel must be a ChannelConfig")
        object.__setattr__(self, "channels", channels)
        boards = tuple(self.io_boards)
        if len(boards) != 2 or any(
            isinstance(b, bool) or not isinstance(b, int) or not 0 <= b <= 2 for b in boards
        ):
            raise UsageError(f"io_boards: {self.io_boards!r} is not (inputs, outputs), each 0..2")
        object.__setattr__(self, "io_boards", boards)
        (speedup,) = _floats("speedup", [self.speedup], 1)
        if speedup <= 0:
            raise UsageError(f"speedup: {speedup} must be above 0")
        object.__setattr__(self, "speedup", speedup)
        (ack,) = _floats("ack_timeout", [self.ack_timeout], 1)
        if ack <= 0:
            raise UsageError(f"ack_timeout: {ack} must be above 0")
        object.__setattr__(self, "ack_timeout", ack)
        if self.seed is not None and (
            isinstance(self.seed, bool) or not isinstance(self.seed, int)
        ):
            raise UsageError(f"seed: {self.seed!r} is not an integer")
        from robostar.sim.dialects import dialect_named

        dialect_named(self.dialect)  # an unknown name is refused here, with the names

    @property
    def served_version(self) -> str:
        """AD's VER: :attr:`version` ending in ``-SIM`` (added, and the text cut to fit the
        20-byte field, when it does not). No setting removes it: a console tells a simulator
        from a robot by it (robostar.commands.identity)."""
        return simulator_version(self.version)

    # -- construction from text ------------------------------------------------------------
    @classmethod
    def from_query(cls, query: Mapping[str, str]) -> SimConfig:
        """From a ``sim://`` URL's query, e.g. ``channels=2&robot=scara,xy&axes=4,2&speedup=20``.

        Keys: ``channels`` (1-3), ``robot`` and ``axes`` (one value for every channel, or a
        comma list per channel), ``auto_servo`` (``enb``/``dis``), ``speedup``, ``ack_timeout``,
        ``io`` (``inputs,outputs``), ``name``, ``version``, ``seed``, ``dialect``. Unknown keys
        are refused.
        """
        known = {
            "channels",
            "robot",
            "axes",
            "auto_servo",
            "speedup",
            "ack_timeout",
            "io",
            "name",
            "version",
            "seed",
            "dialect",
        }
        unknown = sorted(set(query) - known)
        if unknown:
            raise UsageError(
                f"sim:// query: unknown key(s) {', '.join(unknown)}; "
                f"known: {', '.join(sorted(known))}"
            )
        kwargs: dict[str, Any] = {}
        robots = _split(query.get("robot", ""))
        axes_list = _split(query.get("axes", ""))
        if "channels" in query:
            count = _int("channels", query["channels"])
        else:
            count = max(len(robots), len(axes_list)) or len(_default_channels())
        if not 1 <= count <= 3:
            raise UsageError(f"channels: an N1 has 1 to 3 channels, not {count}")
        if robots or axes_list:
            base = _default_channels()
            channels = []
            for i in range(count):
                robot = (
                    robot_type_from_text(_pick("robot", robots, i, count))
                    if robots
                    else (base[i].robot if i < len(base) else RobotType.SCARA)
                )
                default_axes = 4 if robot is RobotType.SCARA else 2
                axes = (
                    _int("axes", _pick("axes", axes_list, i, count)) if axes_list else default_axes
                )
                channels.append(ChannelConfig(robot, axes))
            kwargs["channels"] = tuple(channels)
        else:
            base = _default_channels()
            kwargs["channels"] = tuple(base[i] if i < len(base) else base[0] for i in range(count))
        if "auto_servo" in query:
            kwargs["auto_servo_on"] = _enb("auto_servo", query["auto_servo"])
        if "speedup" in query:
            kwargs["speedup"] = _float("speedup", query["speedup"])
        if "ack_timeout" in query:
            kwargs["ack_timeout"] = _float("ack_timeout", query["ack_timeout"])
        if "io" in query:
            parts = _split(query["io"])
            if len(parts) != 2:
                raise UsageError(f"io: {query['io']!r} is not 'inputs,outputs'")
            kwargs["io_boards"] = (_int("io", parts[0]), _int("io", parts[1]))
        for key in ("name", "version", "dialect"):
            if key in query:
                kwargs[key] = query[key]
        if "seed" in query:
            kwargs["seed"] = _int("seed", query["seed"])
        return cls(**kwargs)

    @classmethod
    def from_file(cls, path: str | PathLike[str]) -> SimConfig:
        """From a TOML file (top-level keys as the fields, ``[[channels]]`` tables per channel)."""
        try:
            with open(path, "rb") as f:
                data = tomllib.load(f)
        except OSError as exc:
            raise UsageError(f"config file {path}: {exc.strerror or exc}") from exc
        except tomllib.TOMLDecodeError as exc:
            raise UsageError(f"config file {path}: not valid TOML: {exc}") from exc
        return cls.from_mapping(data)

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> SimConfig:
        """From a parsed TOML document (or any mapping of the same shape)."""
        fields = {
            "name",
            "version",
            "channels",
            "auto_servo_on",
            "io_boards",
            "speedup",
            "ack_timeout",
            "seed",
        }
        unknown = sorted(set(data) - fields)
        if unknown:
            raise UsageError(f"config: unknown key(s) {', '.join(unknown)}")
        kwargs: dict[str, Any] = {k: v for k, v in data.items() if k != "channels"}
        if "io_boards" in kwargs:
            kwargs["io_boards"] = tuple(kwargs["io_boards"])
        if "auto_servo_on" in kwargs and not isinstance(kwargs["auto_servo_on"], bool):
            raise UsageError("auto_servo_on: must be true or false")
        for key in ("name", "version"):
            if key in kwargs and not isinstance(kwargs[key], str):
                raise UsageError(f"{key}: must be a string")
        if "channels" in data:
            tables = data["channels"]
            if not isinstance(tables, list):
                raise UsageError("channels: must be an array of tables ([[channels]])")
            kwargs["channels"] = tuple(_channel_from_table(i, t) for i, t in enumerate(tables))
        return cls(**kwargs)


def _channel_from_table(index: int, table: Any) -> ChannelConfig:
    where = f"channels[{index}]"
    if not isinstance(table, Mapping):
        raise UsageError(f"{where}: must be a table")
    allowed = {
        "robot",
        "axes",
        "model",
        "limits",
        "link_lengths",
        "max_speed",
        "pulses_per_unit",
        "linear_speed",
    }
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise UsageError(f"{where}: unknown key(s) {', '.join(unknown)}")
    kwargs: dict[str, Any] = dict(table)
    if "robot" in kwargs:
        kwargs["robot"] = robot_type_from_text(str(kwargs["robot"]))
    for key in ("limits", "link_lengths", "max_speed", "pulses_per_unit"):
        if key in kwargs:
            value = kwargs[key]
            if not isinstance(value, list):
                raise UsageError(f"{where}.{key}: must be an array")
            kwargs[key] = tuple(tuple(v) if isinstance(v, list) else v for v in value)
    try:
        return ChannelConfig(**kwargs)
    except UsageError as exc:
        raise UsageError(f"{where}.{exc}") from None


def _split(text: str) -> list[str]:
    return [part.strip() for part in text.split(",") if part.strip()]


def _pick(name: str, values: list[str], index: int, count: int) -> str:
    if len(values) == 1:
        return values[0]
    if len(values) != count:
        raise UsageError(f"{name}: give one value, or one per channel ({count})")
    return values[index]


def _int(name: str, text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise UsageError(f"{name}: {text!r} is not an integer") from None


def _float(name: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise UsageError(f"{name}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise UsageError(f"{name}: {text!r} is not a finite number")
    return value


def _enb(name: str, text: str) -> bool:
    key = text.strip().lower()
    if key in ("enb", "on", "1", "true", "yes"):
        return True
    if key in ("dis", "off", "0", "false", "no"):
        return False
    raise UsageError(f"{name}: {text!r} is not enb or dis")
