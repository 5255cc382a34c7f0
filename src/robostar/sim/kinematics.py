"""Kinematics of the simulated robots: joints <-> XY, arm form, pulses and soft limits.

A SCARA is a two-link arm (axes 1 and 2, degrees) with Z (axis 3, mm) and W (axis 4, degrees);
its XY coordinates are the tool's x, y, z and its angle in the world, ``w = j1 + j2 + j4``. Axes 5
and 6 pass through. The arm form is RIGHT when the elbow angle j2 is >= 0, LEFT when below.
On a cartesian robot (and every other kind) joint values are already mm: XY = angle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from robostar.sim.config import ChannelConfig
from robostar.types import ArmForm, RobotType

__all__ = [
    "Unreachable",
    "arm_of",
    "limit_problem",
    "to_joints",
    "to_pulses",
    "to_xy",
]

_EPS = 1e-9


class Unreachable(Exception):
    """The XY point is outside the arm's reach (or needs a posture it cannot take)."""


def _is_scara(cfg: ChannelConfig) -> bool:
    return cfg.robot is RobotType.SCARA


def arm_of(cfg: ChannelConfig, joints: Sequence[float]) -> ArmForm:
    """The arm form of a joint position (NONE on anything but a SCARA)."""
    if not _is_scara(cfg):
        return ArmForm.NONE
    return ArmForm.RIGHT if joints[1] >= 0 else ArmForm.LEFT


def to_xy(cfg: ChannelConfig, joints: Sequence[float]) -> tuple[float, ...]:
    """Forward kinematics: joint values to XY coordinates (same number of axes)."""
    if not _is_scara(cfg):
        return tuple(joints)
    l1, l2 = cfg.link_lengths
    a1 = math.radians(joints[0])
    a12 = math.radians(joints[0] + joints[1])
    x = l1 * math.cos(a1) + l2 * math.cos(a12)
    y = l1 * math.sin(a1) + l2 * math.sin(a12)
    out = [x, y, *joints[2:]]
    if len(joints) >= 4:
        out[3] = joints[0] + joints[1] + joints[3]
    return tuple(out)


def to_joints(cfg: ChannelConfig, coords: Sequence[float], arm: ArmForm) -> tuple[float, ...]:
    """Inverse kinematics: XY coordinates to joint values in the given arm form.

    ``arm`` NONE on a SCARA means RIGHT (the controller's default posture). Raises
    :class:`Unreachable` when the point is outside the ring the arm can reach.
    """
    if not _is_scara(cfg):
        return tuple(coords)
    l1, l2 = cfg.link_lengths
    x, y = coords[0], coords[1]
    cos2 = (x * x + y * y - l1 * l1 - l2 * l2) / (2 * l1 * l2)
    if cos2 > 1 + _EPS or cos2 < -1 - _EPS:
        reach = math.hypot(x, y)
        raise Unreachable(
            f"X {x:.3f} Y {y:.3f} is {reach:.3f} mm from the base; the arm reaches "
            f"{abs(l1 - l2):.3f} to {l1 + l2:.3f} mm"
        )
    a2 = math.acos(max(-1.0, min(1.0, cos2)))
    if arm is ArmForm.LEFT:
        a2 = -a2
    a1 = math.atan2(y, x) - math.atan2(l2 * math.sin(a2), l1 + l2 * math.cos(a2))
    j1 = math.degrees(a1)
    j2 = math.degrees(a2)
    # atan2 gives -180..180; a joint range beyond that is reached by the nearest equivalent.
    if j1 > 180.0:
        j1 -= 360.0
    elif j1 < -180.0:
        j1 += 360.0
    out = [j1, j2, *coords[2:]]
    if len(coords) >= 4:
        out[3] = coords[3] - j1 - j2
    return tuple(out)


def to_pulses(cfg: ChannelConfig, joints: Sequence[float]) -> tuple[int, ...]:
    """Joint values as encoder pulses."""
    return tuple(round(v * p) for v, p in zip(joints, cfg.pulses_per_unit, strict=False))


def limit_problem(cfg: ChannelConfig, joints: Sequence[float]) -> str | None:
    """Why a joint position breaks the soft limits, or None when it is inside them."""
    for axis, (value, (lo, hi)) in enumerate(zip(joints, cfg.limits, strict=False), start=1):
        if value < lo - 1e-6 or value > hi + 1e-6:
            return f"axis {axis} target {value:.3f} is outside the soft limits {lo:g}..{hi:g}"
    return None
