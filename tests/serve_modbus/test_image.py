"""The map's values before anything is known (sans-IO): a register whose map gives a "none"
value says none (arm form 2, JOB number 65535), not a value a PLC would act on (arm 0 is
"left"), and every block says it has no value or is not in use."""

from __future__ import annotations

from robostar.serve.faces.modbus.image import AGE_NONE, ImageInputs, build_image
from robostar.serve.faces.modbus.layout import BLOCKS, CHANNELS, IR, Quality, channel_base


def test_nothing_known_reads_as_none() -> None:
    inputs = ImageInputs(samples={}, online=True, channels=(1,), io_ports=(0,))
    ir = build_image(inputs, now=1000.0).input_registers
    for ch in CHANNELS:
        base = channel_base(ch)
        assert ir[base + IR.ARM] == 2, ch
        assert ir[base + IR.JOB_NUMBER] == 0xFFFF, ch
    for block in BLOCKS:
        quality = ir[IR.HEALTH + 2 * block.index]
        assert quality in (Quality.NO_VALUE, Quality.NOT_IN_USE), block.name
        assert ir[IR.HEALTH + 2 * block.index + 1] == AGE_NONE, block.name
