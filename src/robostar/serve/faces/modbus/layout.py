"""The Modbus register map of one line: every address, its type, its meaning (pure data).

One map per line (each line is served on a port of its own). Addresses are the protocol's,
0-based; the "PLC" column of the printed map adds the usual 1-based 3xxxx/1xxxx/4xxxx form.
Numbers of 32 bits (floats, global ints) take two registers, **high word first** ("ABCD",
big-endian words and bytes, no swap). The map's version is input register 0: a change of any
address or meaning raises it, so a PLC can refuse a map it was not programmed for.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = [
    "ALARM_SLOTS",
    "AXES",
    "BLOCKS",
    "CHANNELS",
    "DI",
    "HR",
    "IO_PORTS",
    "IR",
    "MAP_VERSION",
    "MAX_GLOBALS",
    "TEXT_REGISTERS",
    "Block",
    "Field",
    "GlobalRange",
    "Outcome",
    "Quality",
    "Reason",
    "Table",
    "channel_base",
    "register_map",
]

MAP_VERSION = 1
CHANNELS = (1, 2, 3)
AXES = 6
IO_PORTS = (0, 1, 2, 3, 4)
ALARM_SLOTS = 8
MAX_GLOBALS = 100
"""Global ints (and floats) the map can hold: 200 registers each."""
TEXT_REGISTERS = 64
"""The refusal text (KD's reason, or the face's): 128 ASCII characters, two per register."""


class Table(enum.Enum):
    """The Modbus tables the map uses (coils: none, every coil address is illegal)."""

    DISCRETE_INPUT = "discrete input"
    INPUT_REGISTER = "input register"
    HOLDING_REGISTER = "holding register"

    @property
    def plc_base(self) -> int:
        """The 1-based prefix PLC manuals write (10001, 30001, 40001)."""
        return {"discrete input": 10001, "input register": 30001, "holding register": 40001}[
            self.value
        ]

    @property
    def function_codes(self) -> str:
        return {"discrete input": "2", "input register": "4", "holding register": "3, 6, 16"}[
            self.value
        ]


class Quality(enum.IntEnum):
    """A block's quality register."""

    GOOD = 0
    STALE = 1
    """Read, but no poll has vouched for it lately (the line is slow, or refused the read)."""
    LINE_DOWN = 2
    NO_VALUE = 3
    """Not read yet since the server started."""
    NOT_IN_USE = 4
    """Not polled in this configuration (a channel without a robot, an unconfigured I/O port,
    no globals): never counted as "not good"."""


class Outcome(enum.IntEnum):
    """The command handshake's outcome register."""

    NONE = 0
    DONE = 1
    REFUSED_BY_CONTROLLER = 2
    """The controller answered an error flag (its flag and KD's reason are published)."""
    REFUSED = 3
    """The face refused it before anything was sent (the reason register says why)."""
    OUTCOME_UNKNOWN = 4
    """Sent, but no answer came: the command may or may not have run."""


class Reason(enum.IntEnum):
    """Why the face refused a command (holding register ``reason``), 0 when it did not."""

    NONE = 0
    UNKNOWN_COMMAND = 1
    BAD_PARAMETER = 2
    NOT_ALLOWED = 3
    """The command is not in the configuration's allowlist."""
    LEASE_HELD = 4
    """Another consumer holds the line's lease."""
    LINE_DOWN = 5
    BUSY = 6
    """Another command of the PLC is still running (stops excepted)."""
    AUDIT_UNAVAILABLE = 7
    NO_SUCH_JOB = 8
    ABORTED = 9
    """Withdrawn or aborted before it was carried out (a stop, the server stopping)."""
    FAILED = 10
    """Any other failure (the text says what)."""
    RESTARTED = 11
    """The first sequence number the face saw since it started: not run (it may be a command
    run before a restart, written again); write a new one."""


@dataclass(frozen=True)
class Block:
    """A group of values read together, with one quality and one age register."""

    index: int
    name: str
    keys: tuple[str, ...]
    """The line model's keys it shows ("global/int", "global/float": the face's own reads)."""
    channel: int | None = None


def _blocks() -> tuple[Block, ...]:
    blocks: list[Block] = []
    for ch in CHANNELS:
        for part in ("status", "position", "angles", "speed", "job", "step"):
            blocks.append(Block(len(blocks), f"ch{ch}.{part}", (f"ch{ch}/{part}",), ch))
    blocks.append(Block(len(blocks), "alarms", ("alarms",)))
    blocks.append(Block(len(blocks), "inputs", tuple(f"io/in/{p}" for p in IO_PORTS)))
    blocks.append(Block(len(blocks), "outputs", tuple(f"io/out/{p}" for p in IO_PORTS)))
    blocks.append(Block(len(blocks), "global_ints", ("global/int",)))
    blocks.append(Block(len(blocks), "global_floats", ("global/float",)))
    return tuple(blocks)


BLOCKS = _blocks()


@dataclass(frozen=True)
class GlobalRange:
    """The global variables the map shows: ``count`` of them from index ``first``."""

    first: int = 0
    count: int = 0

    @property
    def indices(self) -> range:
        return range(self.first, self.first + self.count)


@dataclass(frozen=True)
class Field:
    """One entry of the map: a value at ``address`` of ``table``, ``words`` registers (or bits)."""

    table: Table
    address: int
    words: int
    type: str
    name: str
    description: str
    writable: bool = False
    block: str | None = None

    @property
    def plc_address(self) -> int:
        return self.table.plc_base + self.address

    @property
    def last(self) -> int:
        return self.address + self.words - 1


class IR:
    """Input register addresses (function 4)."""

    MAP_VERSION = 0
    ONLINE = 1
    NOT_GOOD = 2  # uint32, 2 registers
    CHANNELS = 4
    IO_PORTS = 5
    INT_FIRST = 6
    INT_COUNT = 7
    FLOAT_FIRST = 8
    FLOAT_COUNT = 9
    HEALTH = 10
    """Block b: quality at HEALTH + 2b, age (ms) at HEALTH + 2b + 1."""
    # per channel, from channel_base(ch)
    STATUS = 0
    SPEED = 1
    JOB_NUMBER = 2
    STEP = 3
    JOB_NAME = 4  # 6 registers, 12 ASCII characters
    XY_AXES = 10
    ARM = 11
    XY = 12  # 6 float32
    ANGLE_AXES = 24
    ANGLES = 26  # 6 float32
    ALARM_COUNT = 400
    ALARM_CODES = 401
    INPUTS = 500
    OUTPUTS = 505
    IO_POLLED = 510
    """Bit p: port p is polled by the line; a port not polled reads 0 (not "all off")."""
    GLOBAL_INTS = 1000
    GLOBAL_FLOATS = 1200
    SIZE = 1400


class DI:
    """Discrete input addresses (function 2)."""

    STATUS_BITS = ("servo_on", "origin", "alarm", "ready", "in_position", "running")
    STATUS_GOOD = 6  # per channel, after the six status bits
    ONLINE = 48
    INPUTS = 100  # + 16 * port + contact
    OUTPUTS = 200
    SIZE = 288


class HR:
    """Holding register addresses (functions 3, 6, 16): the command handshake."""

    COMMAND = 0
    PARAMS = 1  # P1..P8
    PARAM_COUNT = 8
    SEQUENCE = 9
    WRITABLE = 10
    """Registers 0-9 are written by the PLC (when writes are enabled); the rest are read-only."""
    DONE_SEQUENCE = 10
    OUTCOME = 11
    FLAG = 12
    REASON = 13
    ACCEPTED_SEQUENCE = 14
    TEXT = 16  # TEXT_REGISTERS registers
    SIZE = TEXT + TEXT_REGISTERS


def channel_base(channel: int) -> int:
    """The first input register of ``channel``'s section (100, 200, 300)."""
    return 100 * channel


_AXIS_NAMES = ("1", "2", "3", "4", "5", "6")


def _channel_fields(ch: int) -> list[Field]:
    ir = Table.INPUT_REGISTER
    base = channel_base(ch)
    p = f"ch{ch}"
    fields = [
        Field(
            ir,
            base + IR.STATUS,
            1,
            "bits16",
            f"{p}.status",
            "bit 0 servo on, 1 origin, 2 alarm, 3 ready, 4 in position, 5 running",
            block=f"{p}.status",
        ),
        Field(ir, base + IR.SPEED, 1, "uint16", f"{p}.speed", "speed 0-1000", block=f"{p}.speed"),
        Field(
            ir,
            base + IR.JOB_NUMBER,
            1,
            "uint16",
            f"{p}.job_number",
            "the selected JOB's number (65535: none or not known)",
            block=f"{p}.job",
        ),
        Field(ir, base + IR.STEP, 1, "uint16", f"{p}.step", "current job step", block=f"{p}.step"),
        Field(
            ir,
            base + IR.JOB_NAME,
            6,
            "ascii12",
            f"{p}.job_name",
            "the selected JOB's file name, 2 characters a register, high byte first",
            block=f"{p}.job",
        ),
        Field(
            ir,
            base + IR.XY_AXES,
            1,
            "uint16",
            f"{p}.position.axes",
            "axes in the XY position",
            block=f"{p}.position",
        ),
        Field(
            ir,
            base + IR.ARM,
            1,
            "uint16",
            f"{p}.position.arm",
            "arm form: 0 left, 1 right, 2 none",
            block=f"{p}.position",
        ),
    ]
    for i, axis in enumerate(_AXIS_NAMES):
        fields.append(
            Field(
                ir,
                base + IR.XY + 2 * i,
                2,
                "float32",
                f"{p}.position.{axis}",
                f"XY position, axis {axis} (mm; deg for a rotation; 0 when not in use)",
                block=f"{p}.position",
            )
        )
    fields.append(
        Field(
            ir,
            base + IR.ANGLE_AXES,
            1,
            "uint16",
            f"{p}.angles.axes",
            "axes in the angle position",
            block=f"{p}.angles",
        )
    )
    for i, axis in enumerate(_AXIS_NAMES):
        fields.append(
            Field(
                ir,
                base + IR.ANGLES + 2 * i,
                2,
                "float32",
                f"{p}.angles.{axis}",
                f"joint {axis} (deg; mm on a linear axis; 0 when not in use)",
                block=f"{p}.angles",
            )
        )
    return fields


def register_map(
    ints: GlobalRange = GlobalRange(), floats: GlobalRange = GlobalRange()
) -> tuple[Field, ...]:
    """Every field of the map, in table and address order."""
    ir, di, hr = Table.INPUT_REGISTER, Table.DISCRETE_INPUT, Table.HOLDING_REGISTER
    out: list[Field] = []
    # -- discrete inputs
    for ch in CHANNELS:
        for bit, name in enumerate(DI.STATUS_BITS):
            out.append(
                Field(
                    di,
                    16 * (ch - 1) + bit,
                    1,
                    "bit",
                    f"ch{ch}.{name}",
                    f"channel {ch} {name}",
                    block=f"ch{ch}.status",
                )
            )
        out.append(
            Field(
                di,
                16 * (ch - 1) + DI.STATUS_GOOD,
                1,
                "bit",
                f"ch{ch}.status_good",
                f"channel {ch}'s status bits are good (read lately, line up)",
            )
        )
    out.append(Field(di, DI.ONLINE, 1, "bit", "online", "the line to the controller is up"))
    for label, base, io_block in (("in", DI.INPUTS, "inputs"), ("out", DI.OUTPUTS, "outputs")):
        for port in IO_PORTS:
            out.append(
                Field(
                    di,
                    base + 16 * port,
                    16,
                    "bit",
                    f"io.{label}.{port}.0-15",
                    f"{'input' if label == 'in' else 'output'} port {port}, contacts 0-15",
                    block=io_block,
                )
            )
    # -- input registers
    out += [
        Field(
            ir, IR.MAP_VERSION, 1, "uint16", "map_version", f"this map's version ({MAP_VERSION})"
        ),
        Field(ir, IR.ONLINE, 1, "uint16", "online", "1 while the line to the controller is up"),
        Field(
            ir,
            IR.NOT_GOOD,
            2,
            "uint32",
            "not_good",
            "bit b set: block b's quality is not good (0: every value in use is good)",
        ),
        Field(ir, IR.CHANNELS, 1, "uint16", "channels", f"channels in the map ({len(CHANNELS)})"),
        Field(ir, IR.IO_PORTS, 1, "uint16", "io_ports", f"I/O ports in the map ({len(IO_PORTS)})"),
        Field(ir, IR.INT_FIRST, 1, "uint16", "globals.int.first", "first global int shown"),
        Field(ir, IR.INT_COUNT, 1, "uint16", "globals.int.count", "global ints shown"),
        Field(ir, IR.FLOAT_FIRST, 1, "uint16", "globals.float.first", "first global float shown"),
        Field(ir, IR.FLOAT_COUNT, 1, "uint16", "globals.float.count", "global floats shown"),
    ]
    for block in BLOCKS:
        out.append(
            Field(
                ir,
                IR.HEALTH + 2 * block.index,
                1,
                "uint16",
                f"health.{block.name}.quality",
                f"block {block.index}: 0 good, 1 stale, 2 line down, 3 no value yet, 4 not in use",
            )
        )
        out.append(
            Field(
                ir,
                IR.HEALTH + 2 * block.index + 1,
                1,
                "uint16",
                f"health.{block.name}.age_ms",
                f"block {block.index}: age of its oldest value, ms (65535: that or more, or none)",
            )
        )
    for ch in CHANNELS:
        out += _channel_fields(ch)
    out.append(
        Field(ir, IR.ALARM_COUNT, 1, "uint16", "alarms.count", "active alarms", block="alarms")
    )
    out.append(
        Field(
            ir,
            IR.ALARM_CODES,
            ALARM_SLOTS,
            "uint16",
            f"alarms.code.1-{ALARM_SLOTS}",
            f"the first {ALARM_SLOTS} active alarm codes (0: none)",
            block="alarms",
        )
    )
    for label, base, io_block in (("in", IR.INPUTS, "inputs"), ("out", IR.OUTPUTS, "outputs")):
        for port in IO_PORTS:
            out.append(
                Field(
                    ir,
                    base + port,
                    1,
                    "bits16",
                    f"io.{label}.{port}",
                    f"{'input' if label == 'in' else 'output'} port {port}: bit n = contact n",
                    block=io_block,
                )
            )
    out.append(
        Field(
            ir,
            IR.IO_POLLED,
            1,
            "bits16",
            "io.polled",
            "bit p: port p is polled by the line (a port not polled reads 0, whatever its state)",
        )
    )
    for n, index in enumerate(ints.indices):
        out.append(
            Field(
                ir,
                IR.GLOBAL_INTS + 2 * n,
                2,
                "int32",
                f"global.int.{index}",
                f"global int {index}",
                block="global_ints",
            )
        )
    for n, index in enumerate(floats.indices):
        out.append(
            Field(
                ir,
                IR.GLOBAL_FLOATS + 2 * n,
                2,
                "float32",
                f"global.float.{index}",
                f"global float {index}",
                block="global_floats",
            )
        )
    # -- holding registers: the command handshake
    out.append(
        Field(
            hr, HR.COMMAND, 1, "uint16", "cmd.code", "command code (see the codes)", writable=True
        )
    )
    for n in range(HR.PARAM_COUNT):
        out.append(
            Field(
                hr,
                HR.PARAMS + n,
                1,
                "uint16",
                f"cmd.p{n + 1}",
                f"parameter P{n + 1}",
                writable=True,
            )
        )
    out += [
        Field(
            hr,
            HR.SEQUENCE,
            1,
            "uint16",
            "cmd.sequence",
            "write last: a new value (not 0) runs the command once",
            writable=True,
        ),
        Field(
            hr,
            HR.DONE_SEQUENCE,
            1,
            "uint16",
            "cmd.done_sequence",
            "the sequence number of the last command finished",
        ),
        Field(
            hr,
            HR.OUTCOME,
            1,
            "uint16",
            "cmd.outcome",
            "0 none, 1 done, 2 refused by the controller, 3 refused by this face,"
            " 4 outcome unknown",
        ),
        Field(
            hr,
            HR.FLAG,
            1,
            "uint16",
            "cmd.flag",
            "the controller's error flag (49 = 0x31, 50 = 0x32, 51 = 0x33; 0 none)",
        ),
        Field(hr, HR.REASON, 1, "uint16", "cmd.reason", "why this face refused (see the codes)"),
        Field(
            hr,
            HR.ACCEPTED_SEQUENCE,
            1,
            "uint16",
            "cmd.accepted_sequence",
            "the sequence number of the last command taken (running or finished)",
        ),
        Field(
            hr,
            HR.TEXT,
            TEXT_REGISTERS,
            "ascii128",
            "cmd.text",
            "the refusal's text: KD's reason, or this face's (2 characters a register)",
        ),
    ]
    order = {Table.DISCRETE_INPUT: 0, Table.INPUT_REGISTER: 1, Table.HOLDING_REGISTER: 2}
    return tuple(sorted(out, key=lambda f: (order[f.table], f.address)))
