"""Fault injection on the line: a byte peer that damages, drops, delays and refuses bytes.

:class:`FaultInjector` wraps another :class:`~robostar.transport.peer.BytePeer` (normally the
virtual controller) and sits where the cable would be. Faults are either probabilistic (a rate
per byte, or per packet for the packet-level kinds) or scheduled ("at byte ``k`` of the next
exchange"). Scheduled byte positions count the original bytes of one direction from the start of
the next exchange: the first packet the host sends after the fault was scheduled. Position 0 of
``to_controller`` is that packet's STX; position 0 of ``to_host`` is the first byte the
controller sends after it. Counting then runs on (ACKs, resends, later packets included) until the
fault has fired, so that a test can put a fault at every byte position of an exchange.

Random choices (which byte, which bits) come from one generator per direction seeded from
``seed``, so a run is repeatable however the bytes are split into reads.

The ``--fault`` spec grammar (docs/simulator.md, "Fault injection")::

    KIND[:DIRECTION][:NUMBER[:NUMBER]][@AT][*COUNT]

``corrupt:0.01`` flips bits at a rate of 1 % per byte both ways; ``drop:to_host@5*2`` drops
bytes 5 and 6 of the next answer; ``delay:0.5@3`` holds the answer from its byte 3 for 0.5 s;
``nak*3`` answers the next three host packets with NAK.
"""

from __future__ import annotations

import enum
import math
import random
import threading
from collections import Counter, deque
from dataclasses import dataclass

from robostar.errors import UsageError
from robostar.protocol.frame import ETX, NAK, RST, FramePart, FrameTracker
from robostar.transport.peer import BytePeer

__all__ = [
    "Direction",
    "FaultInjector",
    "FaultKind",
    "FaultSpec",
    "Injection",
    "parse_fault",
]


class Direction(enum.Enum):
    """Which way the damaged bytes travel."""

    TO_HOST = "to_host"
    TO_CONTROLLER = "to_controller"
    BOTH = "both"
    """Rate faults only: line noise on both wires."""


class FaultKind(enum.Enum):
    CORRUPT = "corrupt"
    """Flip bits of a byte (a random non-zero mask unless one is given)."""
    CORRUPT_LRC = "corrupt-lrc"
    """Spoil the LRC byte of a packet so that the receiver must refuse it."""
    DROP = "drop"
    """Lose a byte."""
    DUPLICATE = "dup"
    """Deliver a byte twice."""
    DELAY = "delay"
    """Hold the bytes from this one on for ``seconds`` (order is kept)."""
    NAK_STORM = "nak"
    """Swallow a host packet and answer it with NAK in the controller's place."""
    RST = "rst"
    """Put an RST byte in the stream before this byte."""
    DISCONNECT = "disconnect"
    """Cut the line: this byte and everything after it is lost until the connection is closed
    (the server reads :meth:`FaultInjector.take_disconnect` and closes it)."""
    REPEAT = "repeat"
    """Answers only: send the controller's previous packet again, whole, before this one (a
    peer repeating its previous answer)."""
    LATENCY = "latency"
    """Hold each packet for ``seconds`` (jittered: a random time between ``low`` and
    ``seconds``) before it goes on: a slow controller, a device server with latency."""


_BYTE_KINDS = frozenset((FaultKind.CORRUPT, FaultKind.DROP, FaultKind.DUPLICATE))
"""Kinds where COUNT means that many consecutive bytes."""
_PACKET_KINDS = frozenset(
    (FaultKind.CORRUPT_LRC, FaultKind.NAK_STORM, FaultKind.REPEAT, FaultKind.LATENCY)
)
"""Kinds where COUNT means that many packets."""
_PER_PACKET_RATE = frozenset(
    (
        FaultKind.CORRUPT_LRC,
        FaultKind.NAK_STORM,
        FaultKind.DELAY,
        FaultKind.REPEAT,
        FaultKind.LATENCY,
    )
)
"""Kinds whose rate is a chance per packet, not per byte."""
_KIND_NAMES = {kind.value: kind for kind in FaultKind} | {
    "corrupt_lrc": FaultKind.CORRUPT_LRC,
    "duplicate": FaultKind.DUPLICATE,
    "nak-storm": FaultKind.NAK_STORM,
}
_DIRECTION_NAMES = {d.value: d for d in Direction} | {
    "to-host": Direction.TO_HOST,
    "to-controller": Direction.TO_CONTROLLER,
}


def _usage(spec: str, message: str) -> UsageError:
    return UsageError(f"fault {spec!r}: {message}")


def _as_kind(kind: FaultKind | str) -> FaultKind:
    if isinstance(kind, FaultKind):
        return kind
    found = _KIND_NAMES.get(str(kind).strip().lower())
    if found is None:
        raise UsageError(f"fault kind: {kind!r} is not one of {', '.join(_KIND_NAMES)}")
    return found


def _as_direction(direction: Direction | str) -> Direction:
    if isinstance(direction, Direction):
        return direction
    found = _DIRECTION_NAMES.get(str(direction).strip().lower())
    if found is None:
        raise UsageError(f"fault direction: {direction!r} is not to_host, to_controller or both")
    return found


@dataclass(frozen=True, slots=True)
class FaultSpec:
    """One fault: probabilistic when ``rate`` is set, else scheduled at ``at_byte``.

    ``count`` is consecutive bytes for corrupt/drop/dup and packets for corrupt-lrc/nak;
    ``seconds`` is the hold of a delay or a latency (``low``: a latency's shortest hold, for
    jitter); ``mask`` the bits a scheduled corrupt flips.
    """

    kind: FaultKind
    direction: Direction
    rate: float | None = None
    at_byte: int = 0
    count: int = 1
    seconds: float = 0.0
    mask: int | None = None
    low: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", _as_kind(self.kind))
        object.__setattr__(self, "direction", _as_direction(self.direction))
        for name in ("rate", "seconds", "low"):
            value = getattr(self, name)
            if value is not None and (
                isinstance(value, bool) or not isinstance(value, int | float)
            ):
                raise UsageError(f"fault {name}: {value!r} is not a number")
        text = str(self)
        kind, direction = self.kind, self.direction
        if kind is FaultKind.NAK_STORM and direction is not Direction.TO_CONTROLLER:
            raise _usage(text, "a NAK storm answers host packets: direction is to_controller")
        if kind is FaultKind.REPEAT and direction is not Direction.TO_HOST:
            raise _usage(
                text, "repeat sends the controller's previous answer: direction is to_host"
            )
        if self.rate is not None:
            if not (math.isfinite(self.rate) and 0.0 < self.rate <= 1.0):
                hint = f"; for {self.rate:g} packets write {kind.value}*{self.rate:g}"
                extra = hint if kind in _PACKET_KINDS and self.rate > 1 else ""
                raise _usage(text, f"rate {self.rate!r} is not in (0, 1]{extra}")
            if self.at_byte or self.count != 1:
                raise _usage(text, "a rate fault takes no @AT or *COUNT")
        elif direction is Direction.BOTH:
            raise _usage(text, "a scheduled fault needs one direction (to_host or to_controller)")
        if isinstance(self.at_byte, bool) or not isinstance(self.at_byte, int) or self.at_byte < 0:
            raise _usage(text, f"at_byte {self.at_byte!r} is not a byte position (0 or more)")
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count < 1:
            raise _usage(text, f"count {self.count!r} is not 1 or more")
        if self.count != 1 and kind not in _BYTE_KINDS | _PACKET_KINDS:
            raise _usage(text, f"{kind.value} takes no *COUNT")
        if kind in (FaultKind.DELAY, FaultKind.LATENCY):
            if not (math.isfinite(self.seconds) and self.seconds > 0):
                raise _usage(text, f"{kind.value} seconds {self.seconds!r} must be more than 0")
        elif self.seconds:
            raise _usage(text, f"{kind.value} takes no seconds")
        if self.low is not None:
            if kind is not FaultKind.LATENCY:
                raise _usage(text, "only a latency takes a shortest hold")
            if not (math.isfinite(self.low) and 0 <= self.low <= self.seconds):
                raise _usage(text, f"latency low {self.low!r} must be 0..{self.seconds:g} s")
        if self.mask is not None:
            if kind is not FaultKind.CORRUPT or self.rate is not None:
                raise _usage(text, "only a scheduled corrupt takes a mask")
            if isinstance(self.mask, bool) or not isinstance(self.mask, int):
                raise _usage(text, f"mask {self.mask!r} is not an int")
            if not 1 <= self.mask <= 0xFF:
                raise _usage(text, f"mask 0x{self.mask:X} is not 0x01..0xFF")

    def __str__(self) -> str:
        parts = [self.kind.value, self.direction.value]
        if self.kind in (FaultKind.DELAY, FaultKind.LATENCY):
            parts.append(f"{self.seconds:g}")
        if self.low is not None:
            parts.append(f"{self.low:g}")
        if self.rate is not None and self.kind is FaultKind.LATENCY:
            return ":".join(parts)
        if self.rate is not None:
            parts.append(f"{self.rate:g}")
            return ":".join(parts)
        text = ":".join(parts) + f"@{self.at_byte}"
        return text + (f"*{self.count}" if self.count != 1 else "")


def _number(spec: str, text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise _usage(spec, f"{text!r} is not a number ({what})") from None
    return value


def _whole(spec: str, text: str, what: str) -> int:
    if not text.isdigit():
        raise _usage(spec, f"{text!r} is not a whole number ({what})")
    return int(text)


def parse_fault(spec: str) -> FaultSpec:
    """Read a ``--fault`` spec: ``KIND[:DIRECTION][:NUMBER[:NUMBER]][@AT][*COUNT]``.

    Without a direction, a rate fault hits both wires, a scheduled one the answers (``to_host``),
    and ``nak`` the host's packets. For ``delay`` the first number is the hold in seconds and a
    second one the rate per packet; ``latency:MAX[:MIN]`` holds every answer packet MAX seconds
    (or a random time between MIN and MAX); ``repeat`` sends the controller's previous packet
    again; for the other kinds a number is a rate (0 < rate <= 1).
    Without a rate the fault is scheduled at byte AT (default 0) of the next exchange.
    """
    if not isinstance(spec, str) or not spec.strip():
        raise UsageError(f"fault: {spec!r} is not a fault spec such as 'corrupt:0.01'")
    text = spec.strip().lower()
    count: int | None = None
    at: int | None = None
    if "*" in text:
        text, _, tail = text.rpartition("*")
        count = _whole(spec, tail, "*COUNT")
    if "@" in text:
        text, _, tail = text.rpartition("@")
        at = _whole(spec, tail, "@AT")
    head, *rest = text.split(":")
    if head not in _KIND_NAMES:
        raise _usage(spec, f"{head!r} is not a fault kind ({', '.join(_KIND_NAMES)})")
    kind = _KIND_NAMES[head]
    direction: Direction | None = None
    if rest and rest[0] in _DIRECTION_NAMES:
        direction = _DIRECTION_NAMES[rest.pop(0)]
    numbers = [_number(spec, item, "seconds or rate") for item in rest]
    seconds = 0.0
    low: float | None = None
    if kind in (FaultKind.DELAY, FaultKind.LATENCY):
        if not numbers:
            raise _usage(spec, f"{kind.value} needs its seconds, e.g. {kind.value}:0.5")
        seconds = numbers.pop(0)
    if kind is FaultKind.LATENCY:
        low = numbers.pop(0) if numbers else None
        if numbers:
            raise _usage(spec, "too many numbers (latency:MAX[:MIN])")
        if at is None and count is None:
            numbers = [1.0]  # every packet
    if len(numbers) > 1:
        raise _usage(spec, "too many numbers")
    rate = numbers[0] if numbers else None
    if rate is not None and (at is not None or count is not None):
        raise _usage(spec, "give either a rate or @AT/*COUNT, not both")
    if direction is None:
        if kind is FaultKind.NAK_STORM:
            direction = Direction.TO_CONTROLLER
        elif kind in (FaultKind.REPEAT, FaultKind.LATENCY):
            direction = Direction.TO_HOST
        else:
            direction = Direction.BOTH if rate is not None else Direction.TO_HOST
    return FaultSpec(
        kind,
        direction,
        rate=rate,
        at_byte=at or 0,
        count=1 if count is None else count,
        seconds=seconds,
        low=low,
    )


@dataclass(frozen=True, slots=True)
class Injection:
    """A record of one injected fault: ``index`` counts the direction's original bytes."""

    kind: FaultKind
    direction: Direction
    index: int
    time: float


class _Armed:
    """A scheduled fault waiting for (or running through) its byte positions."""

    __slots__ = ("base", "left", "spec")

    def __init__(self, spec: FaultSpec) -> None:
        self.spec = spec
        self.base: int | None = None  # the direction's byte index where the exchange started
        self.left = spec.count


class _Lane:
    """One direction of the line: its faults, its framing, its queue of bytes to release."""

    def __init__(self, direction: Direction, rng: random.Random) -> None:
        self.direction = direction
        self.rng = rng
        self.index = 0  # original bytes seen so far
        self.framing = FrameTracker()
        self.rates: list[FaultSpec] = []
        self.armed: list[_Armed] = []
        self.queue: deque[tuple[float, bytearray]] = deque()
        self.hold_until = -math.inf  # a delay holds every byte after it until then
        self.swallowing = False  # inside a packet refused by a NAK storm
        self.cut = False
        self.current = bytearray()  # the packet passing now, as it came
        self.last_packet = b""  # the last whole packet that passed (for a repeat)

    def track(self, byte: int, role: FramePart) -> None:
        if role is FramePart.START:
            self.current = bytearray((byte,))
        elif role is FramePart.DATA:
            self.current.append(byte)
        elif role is FramePart.LRC:
            self.current.append(byte)
            self.last_packet = bytes(self.current)

    def emit(self, data: bytes, now: float) -> None:
        release = max(now, self.hold_until)
        if self.queue and self.queue[-1][0] == release:
            self.queue[-1][1].extend(data)
        else:
            self.queue.append((release, bytearray(data)))

    def due(self, now: float) -> bytes:
        out = bytearray()
        while self.queue and self.queue[0][0] <= now:
            out += self.queue.popleft()[1]
        return bytes(out)

    def drop_held(self, now: float) -> None:
        """Lose the bytes a delay still holds (those due by ``now`` were already on the wire)."""
        while self.queue and self.queue[-1][0] > now:
            self.queue.pop()

    def next_release(self) -> float | None:
        return self.queue[0][0] if self.queue else None


class FaultInjector:
    """A byte peer that passes bytes between the host and ``peer``, with faults on the way.

    Add faults with :meth:`add` (a spec string or :class:`FaultSpec`), :meth:`schedule` or
    :meth:`add_rate`. :attr:`injected` counts what was done per (kind, direction) and
    :attr:`log` keeps the latest injections. Methods are thread-safe, so a test can schedule a
    fault while a server thread drives the peer.
    """

    def __init__(self, peer: BytePeer, *, seed: int | None = None) -> None:
        self.peer = peer
        self.seed = seed
        self.injected: Counter[tuple[FaultKind, Direction]] = Counter()
        self.log: deque[Injection] = deque(maxlen=1000)
        self._lock = threading.RLock()
        self._lanes = {
            d: _Lane(d, self._rng(seed, d)) for d in (Direction.TO_HOST, Direction.TO_CONTROLLER)
        }
        self._disconnect = False

    @staticmethod
    def _rng(seed: int | None, direction: Direction) -> random.Random:
        # A string seed is hashed with SHA-512, so the streams are repeatable across runs.
        return random.Random(f"{seed}/{direction.value}") if seed is not None else random.Random()

    # -- configuring ---------------------------------------------------------------------------
    def add(self, fault: FaultSpec | str) -> FaultSpec:
        """Add a fault from a spec string (``"drop:to_host@5"``) or a :class:`FaultSpec`."""
        spec = parse_fault(fault) if isinstance(fault, str) else fault
        if not isinstance(spec, FaultSpec):
            raise UsageError(f"fault: {fault!r} is neither a spec string nor a FaultSpec")
        with self._lock:
            if spec.rate is not None:
                for lane in self._lanes_for(spec.direction):
                    lane.rates.append(spec)
            else:
                self._lanes[spec.direction].armed.append(_Armed(spec))
        return spec

    def schedule(
        self,
        kind: FaultKind | str,
        direction: Direction | str | None = None,
        *,
        at_byte: int = 0,
        count: int = 1,
        seconds: float = 0.0,
        mask: int | None = None,
    ) -> FaultSpec:
        """Inject ``kind`` at byte ``at_byte`` of the next exchange (``count`` bytes/packets).

        ``direction`` defaults to ``to_host`` (``to_controller`` for a NAK storm).
        """
        kind = _as_kind(kind)
        if direction is None:
            direction = (
                Direction.TO_CONTROLLER if kind is FaultKind.NAK_STORM else Direction.TO_HOST
            )
        spec = FaultSpec(
            kind,
            _as_direction(direction),
            at_byte=at_byte,
            count=count,
            seconds=seconds,
            mask=mask,
        )
        return self.add(spec)

    def add_rate(
        self,
        kind: FaultKind | str,
        rate: float,
        direction: Direction | str = Direction.BOTH,
        *,
        seconds: float = 0.0,
    ) -> FaultSpec:
        """Inject ``kind`` at random: ``rate`` per byte (per packet for corrupt-lrc, nak, delay)."""
        kind = _as_kind(kind)
        if kind is FaultKind.NAK_STORM and direction is Direction.BOTH:
            direction = Direction.TO_CONTROLLER
        if isinstance(rate, bool) or not isinstance(rate, int | float):
            raise UsageError(f"fault rate: {rate!r} is not a number")
        spec = FaultSpec(kind, _as_direction(direction), rate=float(rate), seconds=seconds)
        return self.add(spec)

    def clear(self) -> None:
        """Remove every fault (rates and schedules); counters and log stay."""
        with self._lock:
            for lane in self._lanes.values():
                lane.rates.clear()
                lane.armed.clear()

    @property
    def pending(self) -> tuple[FaultSpec, ...]:
        """Scheduled faults that have not fired (or not for all their bytes) yet."""
        with self._lock:
            return tuple(a.spec for lane in self._lanes.values() for a in lane.armed)

    def total(self, kind: FaultKind | None = None, direction: Direction | None = None) -> int:
        """How many faults were injected, optionally of one kind and/or direction."""
        with self._lock:
            return sum(
                n
                for (k, d), n in self.injected.items()
                if (kind is None or k is kind) and (direction is None or d is direction)
            )

    # -- disconnect ----------------------------------------------------------------------------
    @property
    def disconnect_requested(self) -> bool:
        """True once a disconnect fault fired, until :meth:`take_disconnect` is called."""
        return self._disconnect

    def take_disconnect(self) -> bool:
        """Return and clear the disconnect flag. The caller closes the connection; the line is
        whole again for the next one."""
        with self._lock:
            if not self._disconnect:
                return False
            self._disconnect = False
            for lane in self._lanes.values():
                lane.cut = False
                lane.swallowing = False
                lane.framing.reset()
            return True

    # -- BytePeer ------------------------------------------------------------------------------
    def feed(self, data: bytes, now: float) -> None:
        with self._lock:
            self._process(self._lanes[Direction.TO_CONTROLLER], data, now)
            self._feed_peer(now)

    def output(self, now: float) -> bytes:
        with self._lock:
            self._feed_peer(now)
            self._process(self._lanes[Direction.TO_HOST], self.peer.output(now), now)
            return self._lanes[Direction.TO_HOST].due(now)

    def next_deadline(self) -> float | None:
        with self._lock:
            times = [lane.next_release() for lane in self._lanes.values()]
            times.append(self.peer.next_deadline())
            known = [t for t in times if t is not None]
            return min(known) if known else None

    # -- the work ------------------------------------------------------------------------------
    def _lanes_for(self, direction: Direction) -> list[_Lane]:
        if direction is Direction.BOTH:
            return list(self._lanes.values())
        return [self._lanes[direction]]

    def _feed_peer(self, now: float) -> None:
        data = self._lanes[Direction.TO_CONTROLLER].due(now)
        if data:
            self.peer.feed(data, now)

    def _exchange_started(self, index: int) -> None:
        """The host began a packet: scheduled faults waiting for an exchange start counting."""
        for lane in self._lanes.values():
            base = index if lane.direction is Direction.TO_CONTROLLER else lane.index
            for armed in lane.armed:
                if armed.base is None:
                    armed.base = base

    def _record(self, lane: _Lane, kind: FaultKind, index: int, now: float) -> None:
        self.injected[kind, lane.direction] += 1
        self.log.append(Injection(kind, lane.direction, index, now))

    def _firing(self, lane: _Lane, index: int, role: FramePart) -> list[FaultSpec]:
        """The faults that hit the byte at ``index`` (scheduled first, then rates rolled)."""
        hits: list[FaultSpec] = []
        for armed in list(lane.armed):
            if armed.base is None:
                continue
            spec = armed.spec
            position = index - armed.base
            if spec.kind in _PACKET_KINDS:
                wanted = FramePart.LRC if spec.kind is FaultKind.CORRUPT_LRC else FramePart.START
                if role is not wanted or position < spec.at_byte:
                    continue
            elif not spec.at_byte <= position < spec.at_byte + spec.count:
                continue
            hits.append(spec)
            armed.left -= 1
            if armed.left == 0:
                lane.armed.remove(armed)
        for spec in lane.rates:
            if spec.kind is FaultKind.CORRUPT_LRC:
                applies = role is FramePart.LRC
            elif spec.kind in _PER_PACKET_RATE:
                applies = role is FramePart.START
            else:
                applies = True
            if applies and spec.rate is not None and lane.rng.random() < spec.rate:
                hits.append(spec)
        return hits

    def _process(self, lane: _Lane, data: bytes, now: float) -> None:
        if not data:
            return
        host_lane = self._lanes[Direction.TO_HOST]
        # Fast path: no fault can touch these bytes (and no answer fault waits for an exchange
        # to start); keep only the framing and the count.
        quiet = not (lane.rates or lane.armed or lane.swallowing or lane.cut)
        if quiet and (lane is host_lane or not host_lane.armed):
            for byte in data:
                lane.track(byte, lane.framing.step(byte))
            lane.index += len(data)
            lane.emit(data, now)
            return
        for byte in data:
            index = lane.index
            lane.index += 1
            role = lane.framing.step(byte)
            previous = lane.last_packet
            lane.track(byte, role)
            if role is FramePart.START and lane.direction is Direction.TO_CONTROLLER:
                self._exchange_started(index)
            if lane.cut:
                continue
            if lane.swallowing:
                if role is FramePart.LRC:
                    lane.swallowing = False
                    host_lane.emit(bytes((NAK,)), now)
                    continue
                if role is not FramePart.START:
                    continue
                lane.swallowing = False  # cut short by a new packet: judge that one afresh
            self._apply(lane, byte, index, role, now, previous)

    def _apply(
        self, lane: _Lane, byte: int, index: int, role: FramePart, now: float, previous: bytes = b""
    ) -> None:
        hits = self._firing(lane, index, role)
        if not hits:
            lane.emit(bytes((byte,)), now)
            return
        kinds = {spec.kind for spec in hits}
        for spec in hits:
            self._record(lane, spec.kind, index, now)
        if FaultKind.DISCONNECT in kinds:
            self._disconnect = True
            for each in self._lanes.values():
                each.cut = True
                each.drop_held(now)
            return
        if FaultKind.NAK_STORM in kinds:
            lane.swallowing = True
            return
        for spec in hits:
            if spec.kind is FaultKind.DELAY:
                lane.hold_until = max(lane.hold_until, now + spec.seconds)
            elif spec.kind is FaultKind.LATENCY:
                low = spec.seconds if spec.low is None else spec.low
                hold = low if low == spec.seconds else lane.rng.uniform(low, spec.seconds)
                lane.hold_until = max(lane.hold_until, now + hold)
        if FaultKind.REPEAT in kinds and previous:
            lane.emit(previous, now)
        if FaultKind.RST in kinds:
            lane.emit(bytes((RST,)), now)
        if FaultKind.DROP in kinds:
            return
        for spec in hits:
            if spec.kind is FaultKind.CORRUPT:
                byte ^= spec.mask if spec.mask is not None else lane.rng.randrange(1, 256)
        if FaultKind.CORRUPT_LRC in kinds:
            byte = self._spoil_lrc(lane, byte)
        lane.emit(bytes((byte,)) * (2 if FaultKind.DUPLICATE in kinds else 1), now)

    @staticmethod
    def _spoil_lrc(lane: _Lane, byte: int) -> int:
        # The receiver also takes ETX where the XOR is zero, so neither value may come out.
        want = lane.framing.xor
        accepted = {want, ETX} if want == 0 else {want}
        while True:
            spoiled = byte ^ lane.rng.randrange(1, 256)
            if spoiled not in accepted:
                return spoiled
