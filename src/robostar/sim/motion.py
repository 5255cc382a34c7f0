"""Motion planning in model time: joint, linear, arc and circle paths, homing and jog.

Every path runs at constant speed (no acceleration ramps): a joint move lasts as long as its
slowest axis needs at the set speed, so all axes arrive together; an interpolated move (line,
arc, circle) also respects the tool's linear speed. A planned path is checked at many points
along its way against the soft limits and the arm's reach before it starts.
"""

from __future__ import annotations

import enum
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from robostar.sim.config import ChannelConfig
from robostar.sim.kinematics import Unreachable, arm_of, limit_problem, to_joints, to_xy
from robostar.types import ArmForm

__all__ = [
    "HOMING_TIME",
    "Path",
    "PathError",
    "PathProblem",
    "plan_arc",
    "plan_circle",
    "plan_homing",
    "plan_joint",
    "plan_linear",
]

HOMING_TIME = 2.0
"""Model seconds an origin return takes."""
_SAMPLES = 128

Joints = tuple[float, ...]


class PathProblem(enum.Enum):
    LIMIT = "soft limit"
    REACH = "out of reach"
    SHAPE = "impossible path"


class PathError(Exception):
    """A move cannot be made; ``problem`` says which alarm it raises."""

    def __init__(self, problem: PathProblem, message: str):
        self.problem = problem
        self.message = message
        super().__init__(message)


@dataclass(frozen=True)
class Path:
    """A planned move: where it starts and ends, how long it takes, and where it is at ``t``."""

    start: Joints
    end: Joints
    duration: float
    shape: Callable[[float], Joints]
    """Joint values at fraction 0..1 of the path."""
    knots: tuple[Joints, ...] = ()
    """The joint values the shape passes through at evenly spaced fractions, straight between
    them (empty: straight from start to end). The journal records a path by them."""

    def at(self, t: float) -> Joints:
        if self.duration <= 0 or t >= self.duration:
            return self.end
        return self.shape(max(0.0, t) / self.duration)


def _lerp(a: Sequence[float], b: Sequence[float], s: float) -> Joints:
    return tuple(x + (y - x) * s for x, y in zip(a, b, strict=True))


def _joint_time(cfg: ChannelConfig, start: Joints, end: Joints, speed: int) -> float:
    factor = speed / 1000.0
    return max(
        (abs(b - a) / (v * factor) for a, b, v in zip(start, end, cfg.max_speed, strict=True)),
        default=0.0,
    )


def _check(cfg: ChannelConfig, path: Path) -> Path:
    """Refuse a path that leaves the soft limits anywhere along its way."""
    for i in range(_SAMPLES + 1):
        problem = limit_problem(cfg, path.shape(i / _SAMPLES))
        if problem is not None:
            raise PathError(PathProblem.LIMIT, problem)
    return path


def plan_joint(cfg: ChannelConfig, start: Joints, end: Joints, speed: int) -> Path:
    """JMOV: every axis moves at once and all arrive together."""
    problem = limit_problem(cfg, end)
    if problem is not None:
        raise PathError(PathProblem.LIMIT, problem)
    return Path(start, end, _joint_time(cfg, start, end, speed), lambda s: _lerp(start, end, s))


def plan_homing(cfg: ChannelConfig, start: Joints) -> Path:
    """Origin return: to all-zero joints (clamped into the limits) in HOMING_TIME."""
    home = tuple(min(max(0.0, lo), hi) for lo, hi in cfg.limits)
    return Path(start, home, HOMING_TIME, lambda s: _lerp(start, home, s))


def _cartesian(
    cfg: ChannelConfig,
    start: Joints,
    end: Joints,
    curve: Callable[[float], Joints],
    length: float,
    speed: int,
) -> Path:
    """A path defined in XY by ``curve`` (fraction -> XY coordinates), ``length`` mm long."""
    arm = arm_of(cfg, start)
    try:
        samples = [to_joints(cfg, curve(i / _SAMPLES), arm) for i in range(_SAMPLES + 1)]
    except Unreachable as exc:
        raise PathError(PathProblem.REACH, str(exc)) from None
    # Between the checked samples the robot moves in joint space, so it never leaves them.
    samples[0], samples[-1] = start, end

    def shape(s: float) -> Joints:
        i = min(int(s * _SAMPLES), _SAMPLES - 1)
        return _lerp(samples[i], samples[i + 1], s * _SAMPLES - i)

    if arm is not ArmForm.NONE and arm_of(cfg, end) is not arm:
        raise PathError(
            PathProblem.SHAPE,
            "the target needs the other arm form; an interpolated move cannot change it (use JMOV)",
        )
    joint_time = (
        max(
            (_joint_time(cfg, a, b, speed) for a, b in itertools.pairwise(samples)),
            default=0.0,
        )
        * _SAMPLES
    )
    duration = max(joint_time, length / (cfg.linear_speed * speed / 1000.0))
    return _check(cfg, Path(start, end, duration, shape, tuple(samples)))


def plan_linear(cfg: ChannelConfig, start: Joints, end: Joints, speed: int) -> Path:
    """LMOV: a straight line in XY (joint values on a cartesian robot)."""
    a = to_xy(cfg, start)
    b = to_xy(cfg, end)
    length = math.dist(a[:3], b[:3])
    return _cartesian(cfg, start, end, lambda s: _lerp(a, b, s), length, speed)


def _circle(p1: Joints, p2: Joints, p3: Joints) -> tuple[float, float, float]:
    """Centre and radius of the XY circle through three points."""
    (ax, ay), (bx, by), (cx, cy) = p1[:2], p2[:2], p3[:2]
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if abs(d) < 1e-6:
        raise PathError(PathProblem.SHAPE, "the points are on one line; no arc passes them")
    a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    ux = (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / d
    uy = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d
    return ux, uy, math.hypot(ax - ux, ay - uy)


def _sweep(centre: tuple[float, float], a: Joints, via: Joints, b: Joints) -> tuple[float, float]:
    """Start angle and signed sweep from ``a`` to ``b`` passing ``via``."""
    cx, cy = centre
    t0 = math.atan2(a[1] - cy, a[0] - cx)
    tv = (math.atan2(via[1] - cy, via[0] - cx) - t0) % math.tau
    tb = (math.atan2(b[1] - cy, b[0] - cx) - t0) % math.tau
    # Counter-clockwise reaches via before b exactly when via's angle is the smaller.
    return t0, (tb if tv <= tb else tb - math.tau)


def plan_arc(cfg: ChannelConfig, start: Joints, via: Joints, end: Joints, speed: int) -> Path:
    """AMOV: the circular arc from here through ``via`` to ``end`` (XY plane; other axes
    move evenly from start to end)."""
    a, v, b = to_xy(cfg, start), to_xy(cfg, via), to_xy(cfg, end)
    ux, uy, r = _circle(a, v, b)
    t0, sweep = _sweep((ux, uy), a, v, b)

    def curve(s: float) -> Joints:
        t = t0 + sweep * s
        rest = _lerp(a[2:], b[2:], s)
        return (ux + r * math.cos(t), uy + r * math.sin(t), *rest)

    return _cartesian(cfg, start, end, curve, abs(sweep) * r, speed)


def plan_circle(cfg: ChannelConfig, start: Joints, via1: Joints, via2: Joints, speed: int) -> Path:
    """CMOV: the whole circle through here, ``via1`` and ``via2``, back to here (XY plane;
    other axes keep their values)."""
    a, v1, v2 = to_xy(cfg, start), to_xy(cfg, via1), to_xy(cfg, via2)
    ux, uy, r = _circle(a, v1, v2)
    t0, sweep = _sweep((ux, uy), a, v1, v2)
    full = math.tau if sweep > 0 else -math.tau

    def curve(s: float) -> Joints:
        t = t0 + full * s
        return (ux + r * math.cos(t), uy + r * math.sin(t), *a[2:])

    return _cartesian(cfg, start, start, curve, math.tau * r, speed)
