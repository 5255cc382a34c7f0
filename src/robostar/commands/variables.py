"""Global variables: GR (read) and GW (write), each for a point, an integer or a float.

The three variants share their code; the request's first byte (Type: '0' point, '1' integer,
'2' float) picks the class, through :meth:`Command.matches`. Global points are 0-1023 (index
5 bytes, ``"   45"``), integers and floats 0-499 (index 4 bytes, ``"  45"``). Values are sent
right-aligned and space-padded; receivers accept space or zero padding.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar, Self

from robostar.commands.base import (
    Command,
    NoData,
    NumberAnswer,
    NumberField,
    encode_axes,
    read_axes,
)
from robostar.errors import FieldError, MalformedAnswerError
from robostar.protocol.fields import (
    Reader,
    check_range,
    encode_channel,
    encode_code,
    encode_coord,
    parse_coord,
)
from robostar.types import ArmForm, CoordSystem, GlobalKind, Point

__all__ = [
    "ReadGlobalFloat",
    "ReadGlobalInt",
    "ReadGlobalPoint",
    "WriteGlobalFloat",
    "WriteGlobalInt",
    "WriteGlobalPoint",
]

MAX_POINT_INDEX = 1023
MAX_VALUE_INDEX = 499
AXES = 6
INT_WIDTH = 6
INT_MIN = -99999
INT_MAX = 999999
READ_FLOAT_WIDTH = 9
WRITE_FLOAT_WIDTH = 10
POINT_INDEX = NumberField("index", 5, 0, MAX_POINT_INDEX, pad=" ")
VALUE_INDEX = NumberField("index", 4, 0, MAX_VALUE_INDEX, pad=" ")
INT_VALUE = NumberField("value", INT_WIDTH, INT_MIN, INT_MAX, pad=" ")
"""Six bytes hold exactly INT_MIN..INT_MAX, so reading it checks nothing beyond the number."""


def _type_byte(kind: GlobalKind) -> bytes:
    return b"%d" % kind


def _read_type(reader: Reader, kind: GlobalKind) -> None:
    reader.code("Type", int(kind), int(kind))


class _Variant:
    """Mixin for a GR/GW variant: it handles the requests whose Type byte is ``KIND``."""

    __slots__ = ()
    KIND: ClassVar[GlobalKind]

    @classmethod
    def matches(cls, params: bytes) -> bool:
        return params[:1] == _type_byte(cls.KIND)


# -- points ----------------------------------------------------------------------------------
def _point_params(command: str, channel: int, coords: int, axis: int, index: int) -> bytes:
    """Channel, coordinate system, axis and index: the fields GR and GW points share."""
    return (
        _type_byte(GlobalKind.POINT)
        + encode_channel(command, channel)
        + encode_code(command, "coords", coords, 0, 1)
        + encode_code(command, "axis", axis, 0, AXES)
        + POINT_INDEX.encode(command, index)
    )


def _read_point_params(reader: Reader) -> tuple[int, CoordSystem, int, int]:
    _read_type(reader, GlobalKind.POINT)
    channel = reader.channel()
    coords = reader.enum("coords", CoordSystem)
    axis = reader.code("axis", 0, AXES)
    index = POINT_INDEX.read(reader)
    return channel, coords, axis, index


def _encode_point(
    command: str, point: Point, axis: int, *, arm: bool, exact: bool = False
) -> bytes:
    """Point data: all axes (6 x 10 bytes, missing axes as 0.0) + USED + ARM, or the one axis
    + USED (+ ARM when ``arm``, as GW sends it)."""
    if not isinstance(point, Point):
        raise FieldError(command, "point", f"must be a Point, not {type(point).__name__}")
    if axis == 0:
        check_range(command, "point axis count", len(point.axes), 1, AXES)
        values = point.axes + (0.0,) * (AXES - len(point.axes))
    elif len(point.axes) != 1:
        raise FieldError(
            command, "point", f"axis {axis} alone takes one value, not {len(point.axes)}"
        )
    else:
        values = point.axes
    data = encode_axes(command, values, "point", exact=exact)
    data += b"1" if point.used else b"0"
    if axis == 0 or arm:
        data += encode_code(command, "point arm", point.arm, 0, 2)
    return data


def _decode_point(reader: Reader, axis: int, *, arm: bool) -> Point:
    """The inverse of :func:`_encode_point`; a one-axis point read without ARM has arm NONE."""
    axes = read_axes(reader, AXES) if axis == 0 else (reader.coord(f"axis {axis}"),)
    used = bool(reader.code("USED", 0, 1))
    form = reader.enum("ARM", ArmForm) if axis == 0 or arm else ArmForm.NONE
    return Point(axes, form, used)


@dataclass(frozen=True, slots=True)
class ReadGlobalPoint(_Variant, Command[Point]):
    """GR (Type '0'): read global point ``index`` (0-1023) of a channel, all axes or one.

    The answer is ``FLAG '0'`` then, for all axes (``axis`` 0), 6 x 10 bytes + USED + ARM
    (62 bytes); for one axis (1-6), 10 bytes + USED (11), read as a one-value Point with arm
    NONE.
    """

    CODE = "GR"
    KIND = GlobalKind.POINT
    channel: int
    index: int
    coords: CoordSystem = CoordSystem.ANGLE
    axis: int = 0

    def encode_params(self) -> bytes:
        return _point_params(self.CODE, self.channel, self.coords, self.axis, self.index)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel, coords, axis, index = _read_point_params(reader)
        return cls(channel, index, coords, axis)

    def decode_answer(self, packets: Sequence[bytes]) -> Point:
        r = self.single(packets)
        if r.take(1, "Type") != _type_byte(self.KIND):
            raise MalformedAnswerError(self.CODE, "point data does not start with '0'")
        point = _decode_point(r, self.axis, arm=False)
        r.end()
        return point

    def encode_answer(self, result: Point) -> list[bytes]:
        data = _encode_point(self.CODE, result, self.axis, arm=False)
        return [self.ok(_type_byte(self.KIND) + data)]


@dataclass(frozen=True, slots=True)
class WriteGlobalPoint(_Variant, NoData):
    """GW (Type '0'): write global point ``index`` (0-1023) of a channel, all axes or one.

    All axes (``axis`` 0): 6 x 10 bytes + USED + ARM, axes the point lacks sent as 0.0 (so it
    reads back with six values). One axis (1-6): ``point`` holds that one value; 10 bytes +
    USED + ARM. ARM ``NONE`` asks the controller to keep the robot's current posture.
    """

    CODE = "GW"
    CHANGES_STATE = True
    KIND = GlobalKind.POINT
    channel: int
    index: int
    point: Point
    coords: CoordSystem = CoordSystem.ANGLE
    axis: int = 0

    def encode_params(self) -> bytes:
        head = _point_params(self.CODE, self.channel, self.coords, self.axis, self.index)
        return head + _encode_point(self.CODE, self.point, self.axis, arm=True, exact=True)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        channel, coords, axis, index = _read_point_params(reader)
        return cls(channel, index, _decode_point(reader, axis, arm=True), coords, axis)


# -- integers and floats ---------------------------------------------------------------------
def _value_index(command: str, kind: GlobalKind, index: int) -> bytes:
    return _type_byte(kind) + VALUE_INDEX.encode(command, index)


def _read_value_index(reader: Reader, kind: GlobalKind) -> int:
    _read_type(reader, kind)
    return VALUE_INDEX.read(reader)


class _ReadValue(_Variant):
    """Mixin for GR of an integer or a float: the request is Type and ``index``."""

    __slots__ = ()
    CODE: ClassVar[str]
    index: int

    if TYPE_CHECKING:
        # The dataclass mixing this in declares ``index`` and generates the real __init__.
        def __init__(self, index: int) -> None: ...

    def encode_params(self) -> bytes:
        return _value_index(self.CODE, self.KIND, self.index)

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        return cls(_read_value_index(reader, cls.KIND))


@dataclass(frozen=True, slots=True)
class ReadGlobalInt(_ReadValue, NumberAnswer):
    """GR (Type '1'): read global integer ``index`` (0-499); the answer is 6 bytes."""

    CODE = "GR"
    KIND = GlobalKind.INTEGER
    ANSWER = INT_VALUE
    index: int


@dataclass(frozen=True, slots=True)
class WriteGlobalInt(_Variant, NoData):
    """GW (Type '1'): write global integer ``index`` (0-499), 6 bytes (-99999..999999)."""

    CODE = "GW"
    CHANGES_STATE = True
    KIND = GlobalKind.INTEGER
    index: int
    value: int

    def encode_params(self) -> bytes:
        return _value_index(self.CODE, self.KIND, self.index) + INT_VALUE.encode(
            self.CODE, self.value
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        index = _read_value_index(reader, cls.KIND)
        return cls(index, INT_VALUE.read(reader))


@dataclass(frozen=True, slots=True)
class ReadGlobalFloat(_ReadValue, Command[float]):
    """GR (Type '2'): read global float ``index`` (0-499); the answer is 9 bytes, 3 decimals
    (``"12345.123"``)."""

    CODE = "GR"
    KIND = GlobalKind.FLOAT
    index: int

    def decode_answer(self, packets: Sequence[bytes]) -> float:
        # The manual draws 9 bytes ("12345.123"), but a value GW accepted can take 10
        # ("123456.123"): read the number in whatever width the controller sent it.
        r = self.single(packets)
        if r.remaining == 0:
            raise MalformedAnswerError(self.CODE, "the answer holds no value")
        return parse_coord(self.CODE, "value", r.rest(), fixed=False)

    def encode_answer(self, result: float) -> list[bytes]:
        # The manual's 9 bytes when the value fits; a value only GW's 10 bytes hold is sent
        # in 10 (refusing a value the controller itself stored helps nobody).
        text = f"{result:.3f}"
        width = READ_FLOAT_WIDTH if len(text) <= READ_FLOAT_WIDTH else WRITE_FLOAT_WIDTH
        return [self.ok(encode_coord(self.CODE, "value", result, width))]


@dataclass(frozen=True, slots=True)
class WriteGlobalFloat(_Variant, NoData):
    """GW (Type '2'): write global float ``index`` (0-499) as 10 bytes with 3 decimals
    (``"123456.123"``); further decimals are rounded away."""

    CODE = "GW"
    CHANGES_STATE = True
    KIND = GlobalKind.FLOAT
    index: int
    value: float

    def encode_params(self) -> bytes:
        return _value_index(self.CODE, self.KIND, self.index) + encode_coord(
            self.CODE, "value", self.value, WRITE_FLOAT_WIDTH, exact=True
        )

    @classmethod
    def decode_params(cls, reader: Reader) -> Self:
        index = _read_value_index(reader, cls.KIND)
        return cls(index, reader.coord("value", WRITE_FLOAT_WIDTH))
