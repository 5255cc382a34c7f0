"""Replay: a controller that answers from a recorded wire trace.

A user with a real controller records a session (``--trace FILE`` on any command, or
``Client(trace=...)``); :class:`ReplayController` then plays the controller's side of it to any
host: each packet the host sends is matched to the next equal one in the recording, and the
controller's frames that followed it there are sent back. Where the live host sends something
the recording does not hold at that point, the replay sends nothing (the host times out, as it
would against a controller that never heard of it) and notes a :class:`Divergence`.
``robostar sim --replay TRACE`` serves it on TCP like the simulator.

A replay is a simulator too: the AD answers it plays back carry the simulator's mark in their
version (:func:`mark_identity`), so that a recorded robot's identity cannot make a replay pass
for the robot.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import sys
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from robostar.commands.identity import simulator_version
from robostar.commands.status import ReadInfo
from robostar.errors import RobostarError, UsageError
from robostar.protocol.frame import Control, CorruptPacket, FrameDecoder, Packet, encode_packet

__all__ = [
    "Divergence",
    "Recorded",
    "ReplayController",
    "load_trace",
    "mark_identity",
    "serve_replay",
]

_AD_REQUEST = encode_packet(ReadInfo().encode())

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Recorded:
    """One frame of a trace: ``tx`` (host to controller) or ``rx``, the frame's bytes."""

    direction: str
    frame: bytes
    kind: str

    @property
    def is_packet(self) -> bool:
        return self.frame[:1] == b"\x02"


@dataclass(frozen=True, slots=True)
class Divergence:
    """The live host sent ``got`` where the recording (at frame ``index``) held ``expected``."""

    index: int
    expected: bytes | None
    got: bytes

    def __str__(self) -> str:
        wanted = self.expected.hex(" ") if self.expected is not None else "nothing more"
        got = self.got.hex(" ")
        return f"at recorded frame {self.index}: the host sent {got}, the recording has {wanted}"


def load_trace(path: str | os.PathLike[str]) -> list[Recorded]:
    """The frames of a JSON-lines trace (as ``--trace`` writes it), in order."""
    frames: list[Recorded] = []
    try:
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                if not line.strip():
                    continue
                try:
                    record = json.loads(line)
                    direction = record["direction"]
                    frame = bytes.fromhex(record["hex"])
                    kind = str(record.get("kind", ""))
                except (ValueError, KeyError, TypeError) as exc:
                    raise UsageError(
                        f"{os.fspath(path)} line {number}: not a trace record ({exc})"
                    ) from None
                if direction not in ("tx", "rx"):
                    raise UsageError(f"{os.fspath(path)} line {number}: direction {direction!r}")
                frames.append(Recorded(direction, frame, kind))
    except OSError as exc:
        raise UsageError(f"trace {os.fspath(path)}: {exc.strerror or exc}") from None
    if not any(f.direction == "rx" for f in frames):
        raise UsageError(f"trace {os.fspath(path)}: it holds nothing the controller sent")
    return frames


def mark_identity(frames: list[Recorded]) -> list[Recorded]:
    """``frames`` with every AD answer's version ending in the simulator's mark.

    An answer is an AD answer when it follows an AD request in the recording (resends
    included); one that does not decode as such (a corrupt packet, an error flag) is played as
    recorded, as it carries no identity a host could read.
    """
    marked: list[Recorded] = []
    after_ad = False
    for frame in frames:
        if frame.direction == "tx" and frame.is_packet:
            after_ad = frame.frame == _AD_REQUEST
        elif frame.direction == "rx" and frame.is_packet and after_ad:
            frame = Recorded(frame.direction, _marked_ad(frame.frame), frame.kind)
        marked.append(frame)
    return marked


def _marked_ad(raw: bytes) -> bytes:
    events = FrameDecoder().feed(raw)
    if len(events) != 1 or not isinstance(events[0], Packet):
        return raw
    command = ReadInfo()
    try:
        info = command.decode_answer([events[0].data])
        (data,) = command.encode_answer(
            dataclasses.replace(info, version=simulator_version(info.version))
        )
    except RobostarError:
        return raw
    return encode_packet(data)


class ReplayController:
    """A :class:`~robostar.transport.peer.BytePeer` that answers as the recording did."""

    def __init__(self, frames: list[Recorded] | str | os.PathLike[str]) -> None:
        self.frames = mark_identity(load_trace(frames) if not isinstance(frames, list) else frames)
        self.position = 0
        """The next recorded frame to match."""
        self.divergences: list[Divergence] = []
        self.answered = 0
        """Host frames matched to the recording."""
        self._decoder = FrameDecoder()
        self._out = bytearray()
        self._lock = threading.Lock()

    # -- BytePeer ------------------------------------------------------------------------------
    def feed(self, data: bytes, now: float) -> None:
        with self._lock:
            for event in self._decoder.feed(data):
                if isinstance(event, Packet):
                    self._host_sent(encode_packet(event.data), packet=True)
                elif isinstance(event, Control):
                    self._host_sent(bytes((event.kind.value,)), packet=False)
                elif isinstance(event, CorruptPacket):
                    self._host_sent(event.raw, packet=True)

    def output(self, now: float) -> bytes:
        with self._lock:
            out = bytes(self._out)
            self._out.clear()
            return out

    def next_deadline(self) -> float | None:
        return None

    @property
    def finished(self) -> bool:
        """Every recorded frame has been played."""
        return self.position >= len(self.frames)

    # -- matching ------------------------------------------------------------------------------
    def _host_sent(self, frame: bytes, *, packet: bool) -> None:
        found = self._find(frame)
        if found is None:
            if packet:  # a stray control byte (an ACK the recording has not) is no divergence
                expected = next(self._upcoming("tx"), None)
                self.divergences.append(Divergence(self.position, expected, frame))
                log.warning("replay: %s", self.divergences[-1])
            return
        self.position = found + 1
        self.answered += 1
        # The controller's frames that followed in the recording, up to the host's next one.
        while self.position < len(self.frames) and self.frames[self.position].direction == "rx":
            self._out += self.frames[self.position].frame
            self.position += 1

    def _find(self, frame: bytes) -> int | None:
        """The next recorded host frame equal to ``frame``: at once for a control byte, and for
        a packet anywhere ahead (frames skipped on the way are the live host's divergence)."""
        for index in range(self.position, len(self.frames)):
            recorded = self.frames[index]
            if recorded.direction != "tx":
                continue
            if recorded.frame == frame:
                if index > self.position and any(
                    f.direction == "tx" and f.is_packet for f in self.frames[self.position : index]
                ):
                    skipped = self.frames[self.position : index]
                    expected = next((f.frame for f in skipped if f.direction == "tx"), None)
                    self.divergences.append(Divergence(self.position, expected, frame))
                return index
            if len(frame) == 1:
                return None  # control bytes match only the very next host frame
        return None

    def _upcoming(self, direction: str) -> Iterator[bytes]:
        return (f.frame for f in self.frames[self.position :] if f.direction == direction)


def serve_replay(
    path: str | os.PathLike[str],
    *,
    listen: str | None = "127.0.0.1:9100",
    allow_remote: bool = False,
    on_ready: Callable[[list[str]], None] | None = None,
    stop: threading.Event | None = None,
) -> ReplayController:
    """Serve a recording on TCP until Ctrl-C (or ``stop``); says on stderr where the live host
    diverged. One recording is one line: connections share it, as they would share a port."""
    from robostar.listen import parse_listen
    from robostar.sim.host import PeerHost

    replay = ReplayController(path)
    if listen is None:
        raise UsageError("listen: a replay serves on TCP; give an address")
    host_name, port = parse_listen(listen)
    stop = stop if stop is not None else threading.Event()
    host = PeerHost(replay, name="replay")
    try:
        host.listen_tcp(host_name, port, allow_remote=allow_remote)
        host.start()
        if on_ready is not None:
            on_ready(list(host.endpoints))
        while not stop.wait(0.25) and host.failure is None:
            pass
    except KeyboardInterrupt:
        pass
    finally:
        host.close()
        played = f"{replay.position} of {len(replay.frames)} recorded frames played"
        print(f"replay: {played}, {len(replay.divergences)} divergences", file=sys.stderr)
        for divergence in replay.divergences[:20]:
            print(f"  {divergence}", file=sys.stderr)
    return replay
