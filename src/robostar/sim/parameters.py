"""KE parameter data: a plausible text for every index of the manual's PARA and PUB_PARA tables.

The texts are the simulator's own (the manual names the parameters but not their answer format):
``"<NAME>: <values>"``, values per axis where a parameter has them. Those that follow from the
configuration (CONF, LENG, RANG, USING AXIS, AUTO SVON, MAX_CH, NAME, ...) are derived from it.
"""

from __future__ import annotations

from robostar.sim.config import ChannelConfig, SimConfig
from robostar.types import RobotType

__all__ = ["BGT_TEXT", "CHANNEL_NAMES", "PUBLIC_NAMES", "channel_parameters", "public_parameters"]

CHANNEL_NAMES: dict[int, str] = {
    1: "CONF",
    2: "LENG",
    3: "RANG",
    4: "OFFS",
    5: "OFF IMPULSE",
    6: "JNT",
    7: "TOOL",
    8: "MOTOR",
    9: "ENCTY",
    10: "HALL SENSOR",
    11: "MECH END",
    12: "MTYPE",
    21: "ENCTY",
    22: "JOINT",
    23: "LINR",
    24: "DISP",
    25: "MOVE",
    26: "SENS",
    27: "LIMIT",
    31: "INIT_VEL",
    32: "DEC_ZONE",
    33: "STOP_TIME",
    41: "PVG",
    42: "PVG2",
    43: "SMOOTHING FILTER",
    51: "SET",
    52: "FOW",
    53: "OVS",
    54: "OVT",
    55: "OVA",
    56: "IPPE",
    57: "IPA",
    58: "TRQ",
    59: "OVL",
    61: "OND",
    62: "TOL",
    63: "DB",
    71: "RDIS",
    72: "USING AXIS",
    73: "XENB",
    74: "P/R",
    75: "IRNG",
    76: "IRNG",
    77: "DUAL-SYNC",
    91: "S_VEL",
    92: "SEQ",
    93: "DIR",
    94: "RULE",
    95: "SENSOR",
    97: "S_TYPE",
    98: "HOME",
}
"""The manual's PARA table (index -> name)."""

PUBLIC_NAMES: dict[int, str] = {
    1: "TMR",
    2: "HOST-S",
    3: "FDBUS",
    4: "DIO",
    7: "DEADMAN",
    8: "AUTO SVON",
    9: "PLC",
    10: "MAX_CH",
    12: "A I/O",
    51: "W.TIMER",
    52: "CINF",
    53: "PASSWORD",
    54: "NAME",
}
"""The manual's PUB_PARA table (index -> name)."""

BGT_TEXT = "BGT: BACKGROUND TASK"
"""A background-task channel answers this for any index (the manual's note)."""


def _per_axis(cfg: ChannelConfig, values: list[str]) -> str:
    return " ".join(f"{i}:{v}" for i, v in enumerate(values, 1))


def channel_parameters(cfg: ChannelConfig) -> dict[int, str]:
    """Every PARA index of one channel and its text."""
    n = cfg.axes
    kind = cfg.robot.name.replace("_", " ")
    derived = {
        1: f"{kind} {n} AXIS MODEL {cfg.model}",
        2: (
            f"{cfg.link_lengths[0]:.3f} {cfg.link_lengths[1]:.3f}"
            if cfg.robot is RobotType.SCARA
            else "0.000 0.000"
        ),
        3: _per_axis(cfg, [f"{lo:.3f}~{hi:.3f}" for lo, hi in cfg.limits]),
        22: _per_axis(cfg, [f"{v:.1f}" for v in cfg.max_speed]),
        23: f"{cfg.linear_speed:.1f}",
        27: _per_axis(cfg, [f"{lo:.3f}~{hi:.3f}" for lo, hi in cfg.limits]),
        72: " ".join(str(axis) for axis in range(1, n + 1)),
        74: _per_axis(cfg, [f"{p:g}" for p in cfg.pulses_per_unit]),
        98: _per_axis(cfg, ["0.000"] * n),
    }
    out = {}
    for index, name in CHANNEL_NAMES.items():
        value = derived.get(index, _per_axis(cfg, ["0"] * n))
        out[index] = f"{name}: {value}"
    return out


def public_parameters(config: SimConfig) -> dict[int, str]:
    """Every PUB_PARA index and its text (W.TIMER is filled in when read)."""
    inputs, outputs = config.io_boards
    values = {
        1: "10 ms",
        2: "N1 115200 8 N 1",
        3: "NONE",
        4: f"IN {inputs} OUT {outputs}",
        7: "DIS",
        8: "ENB" if config.auto_servo_on else "DIS",
        9: "DIS",
        10: str(len(config.channels)),
        12: "NONE",
        51: "0D 00:00:00",
        52: "N1",
        53: "****",
        54: config.name,
    }
    return {index: f"{PUBLIC_NAMES[index]}: {values[index]}" for index in PUBLIC_NAMES}
