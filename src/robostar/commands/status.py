"""Group A, status: AA (status), AB (current alarms), AC (position), AD (controller info)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Self

from robostar.commands.base import Command, NoParams, Shape, encode_axes, read_axes
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import (
    COORD_WIDTH,
    FLAG_OK,
    Reader,
    decode_using_axes,
    encode_channel,
    encode_code,
    encode_int,
    encode_pulse,
    encode_text,
    encode_using_axes,
)
from robostar.types import (
    Alarm,
    ArmForm,
    ChannelInfo,
    ChannelStatus,
    ControllerInfo,
    Position,
    PositionKind,
    RobotType,
)

__all__ = ["ReadAlarms", "ReadInfo", "ReadPosition", "ReadStatus"]


@dataclass(frozen=True, slots=True)
class ReadStatus(NoParams, Command[tuple[ChannelStatus, ChannelStatus, ChannelStatus]]):
    """AA: read the status byte of all three channels (servo, origin, alarm, ready, ...)."""

    CODE = "AA"

    def decode_answer(
        self, packets: Sequence[bytes]
    ) -> tuple[ChannelStatus, ChannelStatus, ChannelStatus]:
        if len(packets) == 1:
            packet = packets[0]
            # The usual answer, read at once: flag 0x30 (no dummy byte), three status bytes
            # each with bit7=1 bit6=0. Anything else is read field by field, which says what
            # is wrong; both read a good answer alike.
            if len(packet) == 4 and packet[0] == FLAG_OK:
                one, two, three = packet[1], packet[2], packet[3]
                if one & 0xC0 == two & 0xC0 == three & 0xC0 == 0x80:
                    # ChannelStatus.from_byte's table, read directly (three calls fewer)
                    by_bits = ChannelStatus.BY_BITS
                    return (by_bits[one & 0x3F], by_bits[two & 0x3F], by_bits[three & 0x3F])
        return self._decode_fields(packets)

    def _decode_fields(
        self, packets: Sequence[bytes]
    ) -> tuple[ChannelStatus, ChannelStatus, ChannelStatus]:
        r = self.single(packets)
        result = (r.status("channel 1"), r.status("channel 2"), r.status("channel 3"))
        r.end()
        return result

    def encode_answer(
        self, result: tuple[ChannelStatus, ChannelStatus, ChannelStatus]
    ) -> list[bytes]:
        return [self.ok(bytes(status.to_byte() for status in result))]


ALARM_TEXT_WIDTH = 20


@dataclass(frozen=True, slots=True)
class ReadAlarms(NoParams, Command[tuple[Alarm, ...]]):
    """AB: read the current alarms, up to 10, one ``'E' "1153 : T/P Emergency"`` per packet."""

    CODE = "AB"
    SHAPE = Shape.MULTI
    MAX_PACKETS = 10 + 1  # ten alarms and END

    def decode_answer(self, packets: Sequence[bytes]) -> tuple[Alarm, ...]:
        alarms = []
        for body in self.multi_bodies(packets):
            r = Reader(self.CODE, body)
            if r.take(1, "marker") != b"E":
                raise MalformedAnswerError(self.CODE, "alarm text does not start with 'E'", body)
            code = r.number(4, "alarm code")
            if r.take(3, "separator") != b" : ":
                raise MalformedAnswerError(self.CODE, "alarm text lacks ' : '", body)
            alarms.append(Alarm(code, r.rest().decode("ascii", "replace").strip()))
        return tuple(alarms)

    def encode_answer(self, result: tuple[Alarm, ...]) -> list[bytes]:
        packets = []
        for alarm in result[:10]:
            text = alarm.text[:ALARM_TEXT_WIDTH]
            body = (
                b"E"
                + encode_int(self.CODE, "alarm code", alarm.code, 4, lo=0, hi=9999)
                + b" : "
                + encode_text(self.CODE, "alarm text", text, ALARM_TEXT_WIDTH)
            )
            packets.append(self.ok(body))
        return [*packets, self.end()]


@dataclass(frozen=True, slots=True)
class ReadPosition(Command[Position]):
    """AC: read a channel's position in pulses, joint angles or XY, with the arm form."""

    CODE = "AC"
    channel: int
    kind: PositionKind = PositionKind.XY

    def encode_params(self) -> bytes:
        return encode_channel(self.CODE, self.channel) + encode_code(
            self.CODE, "type", self.kind, 0, 2
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        return cls(reader.channel(), reader.enum("type", PositionKind))

    def decode_answer(self, packets: Sequence[bytes]) -> Position:
        r = self.single(packets)
        count, extra = divmod(r.remaining - 1, COORD_WIDTH)
        if extra or not 1 <= count <= 6:
            raise MalformedAnswerError(self.CODE, f"{r.remaining} bytes is not 10 x axes + ARM")
        axes: tuple[float, ...]
        if self.kind is PositionKind.PULSE:
            axes = tuple(r.number(COORD_WIDTH, f"axis {i + 1}") for i in range(count))
        else:
            axes = read_axes(r, count)
        arm = r.enum("ARM", ArmForm)
        return Position(self.kind, axes, arm)

    def encode_answer(self, result: Position) -> list[bytes]:
        if self.kind is PositionKind.PULSE:
            data = b"".join(
                encode_pulse(self.CODE, f"axis {i + 1}", round(v))
                for i, v in enumerate(result.axes)
            )
        else:
            data = encode_axes(self.CODE, result.axes)
        return [self.ok(data + encode_code(self.CODE, "ARM", result.arm, 0, 2))]


NAME_WIDTH = 15
VERSION_WIDTH = 20
MODEL_WIDTH = 10


@dataclass(frozen=True, slots=True)
class ReadInfo(NoParams, Command[ControllerInfo]):
    """AD: read the controller's name, version, and per channel model, type and axes."""

    CODE = "AD"
    ANSWER_DUMMY = True

    def decode_answer(self, packets: Sequence[bytes]) -> ControllerInfo:
        r = self.single(packets)
        max_channels = r.code("MAX CH", 1, 3)
        name = r.text(NAME_WIDTH, "NAME")
        version = r.text(VERSION_WIDTH, "VER")
        models = [r.text(MODEL_WIDTH, f"channel {i + 1} MODEL") for i in range(3)]
        max_axes = [r.code(f"channel {i + 1} MAX AXIS", 0, 6) for i in range(3)]
        types = [r.enum(f"channel {i + 1} TYPE", RobotType) for i in range(3)]
        using = [decode_using_axes(self.CODE, r.byte(f"channel {i + 1} USING")) for i in range(3)]
        r.end()
        channels = tuple(
            ChannelInfo(i + 1, models[i], types[i], max_axes[i], using[i]) for i in range(3)
        )
        return ControllerInfo(max_channels, name, version, channels)

    def encode_answer(self, result: ControllerInfo) -> list[bytes]:
        if len(result.channels) != 3:
            raise FieldError(self.CODE, "channels", "AD always describes three channels")
        data = bytearray()
        data += encode_code(self.CODE, "MAX CH", result.max_channels, 1, 3)
        data += encode_text(self.CODE, "NAME", result.name, NAME_WIDTH)
        data += encode_text(self.CODE, "VER", result.version, VERSION_WIDTH)
        for ch in result.channels:
            data += encode_text(self.CODE, "MODEL", ch.model, MODEL_WIDTH)
        for ch in result.channels:
            data += encode_code(self.CODE, "MAX AXIS", ch.max_axes, 0, 6)
        for ch in result.channels:
            data += encode_code(self.CODE, "TYPE", ch.robot_type, 0, 5)
        for ch in result.channels:
            data += encode_using_axes(self.CODE, ch.axes_in_use)
        return [self.ok(bytes(data))]
