"""The map's values from a line's model: input registers and discrete inputs, with each block's
quality and age (sans-IO: samples and a clock reading in, register values out).

The PLC's reads are answered from here, never from the line: the line's poller keeps the model
fresh at its own pace, and the age and quality registers say how fresh each block is.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field

from robostar.serve.faces.modbus.layout import (
    ALARM_SLOTS,
    AXES,
    BLOCKS,
    CHANNELS,
    DI,
    IO_PORTS,
    IR,
    MAP_VERSION,
    Block,
    GlobalRange,
    Quality,
    channel_base,
)
from robostar.serve.model import Quality as ModelQuality
from robostar.serve.model import Sample

__all__ = ["AGE_NONE", "Image", "ImageInputs", "build_image", "float_words", "text_words"]

AGE_NONE = 0xFFFF
"""The age register of a block with no value (and the ceiling of every age, 65.535 s)."""
NO_JOB = 0xFFFF
_ARM_NONE = 2


@dataclass
class ImageInputs:
    """What the map shows: the model's samples (by key), the face's own global reads, what this
    line polls (channels, ports), and the JOB numbers known by file name per channel."""

    samples: Mapping[str, Sample]
    online: bool
    channels: Collection[int]
    io_ports: Collection[int]
    ints: GlobalRange = field(default_factory=GlobalRange)
    floats: GlobalRange = field(default_factory=GlobalRange)
    global_ints: Mapping[int, Sample] = field(default_factory=dict)
    global_floats: Mapping[int, Sample] = field(default_factory=dict)
    job_numbers: Mapping[int, Mapping[str, int]] = field(default_factory=dict)


def float_words(value: float) -> tuple[int, int]:
    """A float32 as two registers, high word first."""
    if not math.isfinite(value):
        value = 0.0
    high, low = struct.unpack(">HH", struct.pack(">f", value))
    return int(high), int(low)


def _int_words(value: int) -> tuple[int, int]:
    value = max(-(2**31), min(2**31 - 1, value))
    high, low = struct.unpack(">HH", struct.pack(">i", value))
    return int(high), int(low)


def text_words(text: str, registers: int) -> list[int]:
    """ASCII text in ``registers`` registers, two characters each, high byte first, 0-padded."""
    data = text.encode("ascii", "replace")[: 2 * registers].ljust(2 * registers, b"\0")
    return [int.from_bytes(data[i : i + 2], "big") for i in range(0, len(data), 2)]


_QUALITY = {
    ModelQuality.GOOD: Quality.GOOD,
    ModelQuality.STALE: Quality.STALE,
    ModelQuality.LINE_DOWN: Quality.LINE_DOWN,
}


def _health(
    samples: list[Sample | None], in_use: bool, online: bool
) -> tuple[Quality, float | None]:
    """A block's quality (the worst of its values; never good while the line is down) and
    the time its oldest value was read (None: no value)."""
    if not in_use:
        return Quality.NOT_IN_USE, None
    if not samples or any(s is None for s in samples):
        return Quality.NO_VALUE, None
    present = [s for s in samples if s is not None]
    quality = max((_QUALITY[s.quality] for s in present), default=Quality.GOOD)
    if not online:
        quality = max(quality, Quality.LINE_DOWN)
    return quality, min(s.at for s in present)


@dataclass
class Image:
    """The tables' values; only the age registers change with time (:meth:`set_ages`)."""

    input_registers: list[int]
    discrete_inputs: list[bool]
    read_at: list[float | None]
    """By block: when its oldest value was read (``time.time()``), None without a value."""

    def set_ages(self, now: float) -> None:
        """Write every block's age as of ``now`` (ms, at most :data:`AGE_NONE`)."""
        ir = self.input_registers
        for index, at in enumerate(self.read_at):
            age = AGE_NONE if at is None else min(int(max(0.0, now - at) * 1000), AGE_NONE)
            ir[IR.HEALTH + 2 * index + 1] = age


def _block_samples(block: Block, inputs: ImageInputs) -> tuple[list[Sample | None], bool]:
    if block.channel is not None:
        return [inputs.samples.get(block.keys[0])], block.channel in inputs.channels
    if block.name in ("inputs", "outputs"):
        side = "in" if block.name == "inputs" else "out"
        ports = sorted(inputs.io_ports)
        return [inputs.samples.get(f"io/{side}/{p}") for p in ports], bool(ports)
    if block.name == "global_ints":
        return [inputs.global_ints.get(i) for i in inputs.ints.indices], inputs.ints.count > 0
    if block.name == "global_floats":
        indices = inputs.floats.indices
        return [inputs.global_floats.get(i) for i in indices], inputs.floats.count > 0
    return [inputs.samples.get(block.keys[0])], True


def _value(inputs: ImageInputs, key: str) -> object:
    sample = inputs.samples.get(key)
    return None if sample is None else sample.value


def build_image(inputs: ImageInputs, now: float) -> Image:
    """The input registers (IR.SIZE of them) and discrete inputs (DI.SIZE) as of ``now``."""
    ir = [0] * IR.SIZE
    di = [False] * DI.SIZE
    ir[IR.MAP_VERSION] = MAP_VERSION
    ir[IR.ONLINE] = 1 if inputs.online else 0
    ir[IR.CHANNELS] = len(CHANNELS)
    ir[IR.IO_PORTS] = len(IO_PORTS)
    ir[IR.INT_FIRST], ir[IR.INT_COUNT] = inputs.ints.first, inputs.ints.count
    ir[IR.FLOAT_FIRST], ir[IR.FLOAT_COUNT] = inputs.floats.first, inputs.floats.count
    di[DI.ONLINE] = inputs.online
    not_good = 0
    good: dict[str, bool] = {}
    read_at: list[float | None] = []
    for block in BLOCKS:
        samples, in_use = _block_samples(block, inputs)
        quality, at = _health(samples, in_use, inputs.online)
        ir[IR.HEALTH + 2 * block.index] = int(quality)
        read_at.append(at)
        good[block.name] = quality is Quality.GOOD
        if quality not in (Quality.GOOD, Quality.NOT_IN_USE):
            not_good |= 1 << block.index
    ir[IR.NOT_GOOD], ir[IR.NOT_GOOD + 1] = not_good >> 16, not_good & 0xFFFF
    for ch in CHANNELS:
        _channel(ir, di, inputs, ch, good[f"ch{ch}.status"])
    alarms = _value(inputs, "alarms")
    if isinstance(alarms, tuple | list):
        ir[IR.ALARM_COUNT] = min(len(alarms), 0xFFFF)
        for n, alarm in enumerate(alarms[:ALARM_SLOTS]):
            ir[IR.ALARM_CODES + n] = max(0, min(int(getattr(alarm, "code", 0)), 0xFFFF))
    ir[IR.IO_POLLED] = sum(1 << port for port in inputs.io_ports if port in IO_PORTS)
    for port in IO_PORTS:
        for side, ir_base, di_base in (
            ("in", IR.INPUTS, DI.INPUTS),
            ("out", IR.OUTPUTS, DI.OUTPUTS),
        ):
            state = _value(inputs, f"io/{side}/{port}")
            contacts = getattr(state, "contacts", None)
            if contacts is None:
                continue
            word = 0
            for contact, on in enumerate(contacts[:16]):
                if on:
                    word |= 1 << contact
                    di[di_base + 16 * port + contact] = True
            ir[ir_base + port] = word
    for n, index in enumerate(inputs.ints.indices):
        sample = inputs.global_ints.get(index)
        if sample is not None:
            ir[IR.GLOBAL_INTS + 2 * n : IR.GLOBAL_INTS + 2 * n + 2] = _int_words(int(sample.value))
    for n, index in enumerate(inputs.floats.indices):
        sample = inputs.global_floats.get(index)
        if sample is not None:
            words = float_words(float(sample.value))
            ir[IR.GLOBAL_FLOATS + 2 * n : IR.GLOBAL_FLOATS + 2 * n + 2] = words
    image = Image(ir, di, read_at)
    image.set_ages(now)
    return image


def _channel(
    ir: list[int], di: list[bool], inputs: ImageInputs, ch: int, status_good: bool
) -> None:
    base = channel_base(ch)
    status = _value(inputs, f"ch{ch}/status")
    if status is not None:
        word = 0
        for bit, name in enumerate(DI.STATUS_BITS):
            on = bool(getattr(status, name, False))
            if on:
                word |= 1 << bit
            di[16 * (ch - 1) + bit] = on
        ir[base + IR.STATUS] = word
    di[16 * (ch - 1) + DI.STATUS_GOOD] = status_good
    speed = _value(inputs, f"ch{ch}/speed")
    if isinstance(speed, int):
        ir[base + IR.SPEED] = max(0, min(speed, 0xFFFF))
    job = _value(inputs, f"ch{ch}/job")
    name = "" if job is None else str(job)
    ir[base + IR.JOB_NUMBER] = inputs.job_numbers.get(ch, {}).get(name.upper(), NO_JOB)
    ir[base + IR.JOB_NAME : base + IR.JOB_NAME + 6] = text_words(name, 6)
    step = _value(inputs, f"ch{ch}/step")
    if isinstance(step, int):
        ir[base + IR.STEP] = max(0, min(step, 0xFFFF))
    ir[base + IR.ARM] = _ARM_NONE  # until a position says otherwise (0 would say "left")
    for key, count_at, arm_at, first in (
        ("position", IR.XY_AXES, IR.ARM, IR.XY),
        ("angles", IR.ANGLE_AXES, None, IR.ANGLES),
    ):
        position = _value(inputs, f"ch{ch}/{key}")
        axes = getattr(position, "axes", None)
        if axes is None:
            continue
        ir[base + count_at] = min(len(axes), AXES)
        if arm_at is not None:
            ir[base + arm_at] = int(getattr(position, "arm", _ARM_NONE))
        for i, value in enumerate(axes[:AXES]):
            ir[base + first + 2 * i : base + first + 2 * i + 2] = float_words(float(value))
