"""Packet framing: ``STX DATA ETX LRC`` and the lone control bytes, with no I/O.

:func:`encode_packet` builds a packet. :class:`FrameDecoder` is fed bytes in any split and yields
:class:`Packet`, :class:`Control` and :class:`CorruptPacket` events. It keeps only the unfinished
frame between feeds, so a bad LRC or an overlong frame never wedges it: it reports the damage and
resynchronises on the next STX (the lesson of pymodbus's framer bugs).
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass

from robostar.errors import FrameError, PacketTooLongError

__all__ = [
    "ACK",
    "DUMMY",
    "ETX",
    "MAX_PACKET",
    "NAK",
    "RST",
    "STX",
    "Control",
    "CorruptPacket",
    "CorruptReason",
    "FrameDecoder",
    "FrameEvent",
    "FramePart",
    "FrameTracker",
    "Packet",
    "encode_packet",
    "lone_frame",
    "lrc",
]

STX = 0x02
ETX = 0x03
ACK = 0x06
NAK = 0x15
RST = 0x12
DUMMY = 0xFF
MAX_PACKET = 250
"""Longest packet, STX to LRC included."""

_MAX_DATA = MAX_PACKET - 3
_LRC_FOLD_FROM = 48
"""From this many bytes on, folding the packet as one integer beats a loop over its bytes."""
_CONTROL_BYTES = frozenset((ACK, NAK, RST))
_LONE_FRAME = re.compile(rb"\x02([^\x02\x03]{0,%d})\x03." % _MAX_DATA, re.DOTALL).fullmatch
"""STX, up to 247 data bytes holding neither STX nor ETX, ETX, any LRC byte: one whole frame
(one C call; the same test as two ``find`` calls and the bounds, in about half the time)."""


def lrc(data: bytes | bytearray) -> int:
    """XOR of every data byte (the dummy byte included), as the manual computes it."""
    width = len(data)
    if width < _LRC_FOLD_FROM:
        value = 0
        for byte in data:
            value ^= byte
        return value
    # A long packet: fold the bytes as one integer, halving its width each time (a handful
    # of integer operations instead of one Python step per byte).
    value = int.from_bytes(data, "little")
    while width > 1:
        half = width >> 1
        bits = half << 3
        value = (value & ((1 << bits) - 1)) ^ (value >> bits)
        width -= half
    return value


def encode_packet(data: bytes) -> bytes:
    """Frame ``data`` as ``STX data ETX LRC``.

    A zero LRC is sent as 0x03, as the manual says. Data longer than the 250-byte packet allows,
    or data holding STX/ETX (which no field may contain), is refused before anything is sent.
    """
    if len(data) > _MAX_DATA:
        raise PacketTooLongError(
            "", "packet", f"{len(data) + 3} bytes is over the {MAX_PACKET}-byte limit"
        )
    if STX in data or ETX in data:
        raise PacketTooLongError("", "packet", "data may not contain STX (0x02) or ETX (0x03)")
    check = lrc(data)
    return bytes((STX, *data, ETX, check if check else ETX))


def lone_frame(data: bytes) -> bytes | None:
    """The packet data of ``data`` when it is exactly one whole frame with a good LRC (STX,
    data holding neither STX nor ETX, ETX, LRC; 250 bytes at most), or None.

    A shortcut for the usual read, an answer arriving whole: where this gives data,
    :meth:`FrameDecoder.feed` between frames gives just ``[Packet(data)]`` and stays between
    frames. Anything else (None) is for the decoder.
    """
    whole = _LONE_FRAME(data)
    if whole is not None:
        packet = whole.group(1)
        got = data[-1]
        want = lrc(packet)
        if got == want or (want == 0 and got == ETX):
            return packet
    return None


@dataclass(frozen=True, slots=True)
class Packet:
    """A whole packet with a good LRC; ``data`` is what stood between STX and ETX."""

    data: bytes


class ControlKind(enum.IntEnum):
    ACK = ACK
    NAK = NAK
    RST = RST


@dataclass(frozen=True, slots=True)
class Control:
    """A lone control byte: ACK, NAK or RST."""

    kind: ControlKind


class CorruptReason(enum.Enum):
    BAD_LRC = "bad LRC"
    TOO_LONG = "longer than 250 bytes"
    TRUNCATED = "cut short by a new STX"


@dataclass(frozen=True, slots=True)
class CorruptPacket:
    """A packet that arrived damaged; the receiver should answer NAK."""

    reason: CorruptReason
    raw: bytes


FrameEvent = Packet | Control | CorruptPacket


class FramePart(enum.Enum):
    """What a byte of the line is to the framing (:meth:`FrameTracker.step`)."""

    START = "start"
    """An STX opening a packet (or restarting one that was cut short)."""
    DATA = "data"
    """Inside a packet, its ETX included."""
    LRC = "lrc"
    """The byte after ETX, whatever its value."""
    OTHER = "other"
    """A control byte or noise between packets."""


class FrameTracker:
    """Where a stream of bytes stands in the framing, and the LRC its packet's data call for,
    without keeping the data: the one framing state machine. :class:`FrameDecoder` runs on it
    (and keeps the data and the 250-byte limit); so do those that pass bytes on rather than
    decode them (the simulator's fault injection, the threaded host's record of a half-sent
    packet).

    The rule: STX (re)starts a packet; inside one every byte but ETX counts in the XOR; after
    ETX the next byte is the LRC whatever it is; between packets nothing but STX matters.
    """

    __slots__ = ("in_lrc", "in_packet", "xor")

    def __init__(self) -> None:
        self.in_packet = False
        self.in_lrc = False
        self.xor = 0
        """The XOR of the current packet's data so far."""

    def step(self, byte: int) -> FramePart:
        """Take one byte; say what it is."""
        if self.in_lrc:
            self.in_lrc = False
            return FramePart.LRC
        if byte == STX:
            self.in_packet = True
            self.xor = 0
            return FramePart.START
        if not self.in_packet:
            return FramePart.OTHER
        if byte == ETX:
            self.in_packet = False
            self.in_lrc = True
        else:
            self.xor ^= byte
        return FramePart.DATA

    def fold(self, data: bytes, start: int, end: int) -> int:
        """Inside a packet: take ``data[start:end]`` up to its first STX or ETX at once, its
        data bytes folded into the XOR. Returns where that STX or ETX stands, taken as
        :meth:`step` takes it (ETX: the LRC is next; STX: a new packet begins), or ``end``
        when there is none (still inside the packet)."""
        etx = data.find(b"\x03", start, end)
        stx = data.find(b"\x02", start, end)
        stop = end if etx < 0 else etx
        if 0 <= stx < stop:
            stop = stx
        if stop > start:
            self.xor ^= lrc(data[start:stop])
        if stop != end:
            if stop == stx:
                self.xor = 0
            else:
                self.in_packet = False
                self.in_lrc = True
        return stop

    def feed(self, data: bytes) -> None:
        """Take a read whole: the same state as :meth:`step` over each byte, with the runs
        between STX and ETX folded at once (as :meth:`fold` folds them)."""
        i = 0
        n = len(data)
        if not (self.in_packet or self.in_lrc):
            i = data.find(b"\x02")
            if i < 0:
                return
            # The usual read: one whole packet (lone_frame's test; its ETX second to last
            # first), between packets after it as before it.
            whole = _LONE_FRAME(data, i) if data[n - 2] == ETX else None
            if whole is not None:
                self.xor = lrc(whole.group(1))
                return
            self.in_packet = True  # the STX found: a packet begins
            self.xor = 0
            i += 1
        while i < n:
            if self.in_lrc:
                self.in_lrc = False
                i += 1
            elif self.in_packet:
                # fold(data, i, n), inline: the simulator's host passes every read through
                # here, and a frame split over reads (a serial line, a pty) comes this way
                etx = data.find(b"\x03", i)
                stx = data.find(b"\x02", i)
                stop = n if etx < 0 else etx
                if 0 <= stx < stop:
                    stop = stx
                self.xor ^= lrc(data[i:stop])
                if stop == n:
                    return
                if stop == stx:
                    self.xor = 0
                else:
                    self.in_packet = False
                    self.in_lrc = True
                i = stop + 1
            else:
                stx = data.find(b"\x02", i)
                if stx < 0:
                    return
                self.in_packet = True
                self.xor = 0
                i = stx + 1

    def closing_bytes(self) -> bytes:
        """Bytes that end the packet begun as a corrupt one (empty between packets): ETX if it
        is still open, and an LRC byte that is neither the right one nor the ETX a receiver
        takes for a zero LRC."""
        wrong = self.xor ^ 0xFF
        if self.in_packet:
            return bytes((ETX, wrong))
        if self.in_lrc:
            return bytes((wrong,))
        return b""

    def reset(self) -> None:
        """Between packets again (the line was cleared)."""
        self.in_packet = self.in_lrc = False
        self.xor = 0


_CONTROL_EVENTS = {kind.value: Control(kind) for kind in ControlKind}
_BYTES_TYPES = (bytes, bytearray, memoryview)


class _State(enum.Enum):
    """Where the decoder stands, in one word (:attr:`FrameDecoder._state`): its tracker's
    place in the framing, and whether the frame open was already reported overlong."""

    HUNT = "hunt"  # between frames: control bytes count, anything else is line noise
    DATA = "data"  # inside a frame, collecting data up to ETX
    LRC = "lrc"  # ETX seen; the next byte is the LRC, whatever its value
    SKIP = "skip"  # overlong frame already reported; drop bytes up to its end
    SKIP_LRC = "skip_lrc"  # overlong frame's ETX seen; drop its LRC byte


class FrameDecoder:
    """Incremental decoder: :meth:`feed` bytes, get events.

    Between frames, ACK/NAK/RST are control events and other bytes are counted in
    :attr:`discarded`. A frame runs from STX to the byte after ETX. A new STX inside a frame
    ends the old one as ``TRUNCATED``; a frame passing 250 bytes is reported ``TOO_LONG`` at once
    and skipped to its end.

    The framing (where a frame begins and ends, and the XOR its LRC must match) is a
    :class:`FrameTracker`'s; the decoder keeps the frame's data and the 250-byte limit.
    """

    __slots__ = ("_buf", "_framing", "_overlong", "between_frames", "discarded")

    def __init__(self) -> None:
        self._buf = bytearray()
        self._framing = FrameTracker()
        self._overlong = False
        """The frame open was reported TOO_LONG: its bytes are dropped up to its end."""
        self.between_frames = True
        """No frame is begun: the next byte is read as a frame's start, a control byte or
        noise. (Kept with the state, not computed: the usual read asks it every time.)"""
        self.discarded = 0

    @property
    def pending(self) -> int:
        """Bytes of an unfinished frame held for the next feed."""
        return len(self._buf)

    @property
    def _state(self) -> _State:
        framing = self._framing
        if framing.in_packet:
            return _State.SKIP if self._overlong else _State.DATA
        if framing.in_lrc:
            return _State.SKIP_LRC if self._overlong else _State.LRC
        return _State.HUNT

    def reset(self) -> None:
        """Forget any unfinished frame (after RST, or when the line is reopened)."""
        self._buf.clear()
        self._framing.reset()
        self._overlong = False
        self.between_frames = True

    def feed(self, data: bytes | bytearray | memoryview) -> list[FrameEvent]:
        """Take bytes from the line; return the events they complete, in order."""
        if not isinstance(data, _BYTES_TYPES):
            raise FrameError(f"FrameDecoder.feed takes bytes, not {type(data).__name__}")
        view = bytes(data)
        n = len(view)
        events: list[FrameEvent] = []
        i = 0
        if self.between_frames:
            # The usual read: control bytes (an ACK before the next request), then exactly
            # one whole frame. The same events as the general loop below, in fewer steps
            # (and the framing between frames after it, as before it).
            while i < n and view[i] in _CONTROL_BYTES:
                events.append(_CONTROL_EVENTS[view[i]])
                i += 1
            whole = _LONE_FRAME(view, i)  # the rest is one whole frame (lone_frame's test)
            if whole is not None:
                data_bytes = whole.group(1)
                got = view[n - 1]
                want = lrc(data_bytes)
                if got == want or (want == 0 and got == ETX):
                    events.append(Packet(data_bytes))
                else:
                    events.append(CorruptPacket(CorruptReason.BAD_LRC, view[i:]))
                return events
        buf = self._buf
        framing = self._framing
        while i < n:
            if framing.in_packet:
                if self._overlong:
                    # Reported already: drop its bytes up to its ETX (then its LRC byte), or
                    # up to an STX, which begins the next frame.
                    stop = framing.fold(view, i, n)
                    if stop == n:
                        self.discarded += n - i
                        i = n
                    elif framing.in_lrc:
                        self.discarded += stop + 1 - i
                        i = stop + 1
                    else:
                        self.discarded += stop - i
                        self._overlong = False
                        i = stop + 1
                    continue
                # Take a run of data bytes at once up to the next ETX or STX, but never past
                # the byte that makes the frame too long: the verdict must not depend on how
                # the bytes were split into reads.
                end = i + _MAX_DATA + 1 - len(buf)
                if end > n:
                    end = n
                stop = framing.fold(view, i, end)
                buf += view[i:stop]
                if stop == end:
                    i = stop
                    if len(buf) > _MAX_DATA:
                        events.append(CorruptPacket(CorruptReason.TOO_LONG, bytes((STX, *buf))))
                        buf.clear()
                        self._overlong = True
                elif framing.in_lrc:  # its ETX
                    i = stop + 1
                else:  # an STX: the frame was cut short, and the next one begins
                    events.append(CorruptPacket(CorruptReason.TRUNCATED, bytes((STX, *buf))))
                    buf.clear()
                    i = stop + 1
            elif framing.in_lrc:
                got = view[i]
                i += 1
                framing.step(got)
                if self._overlong:
                    self.discarded += 1
                    self._overlong = False
                    continue
                want = framing.xor
                if got == want or (want == 0 and got == ETX):
                    events.append(Packet(bytes(buf)))
                else:
                    raw = bytes((STX, *buf, ETX, got))
                    events.append(CorruptPacket(CorruptReason.BAD_LRC, raw))
                buf.clear()
            else:
                byte = view[i]
                i += 1
                if byte == STX:
                    framing.step(byte)  # a frame begins
                    buf.clear()
                elif byte in _CONTROL_BYTES:
                    events.append(_CONTROL_EVENTS[byte])
                else:
                    self.discarded += 1
        self.between_frames = not (framing.in_packet or framing.in_lrc)
        return events
