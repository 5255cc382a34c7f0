"""Fuzz targets: each takes arbitrary input, runs one part of robostar on it, checks invariants.

A target raises :class:`Violation` when robostar breaks a promise (an untyped exception, a
packet with a bad LRC let through, a result that depends on how bytes were split, a link left
waiting with no timer). The library's own typed errors are expected outcomes, not violations.
The hypothesis tests, the long-run fuzzer and the atheris harness all call these same targets.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

from robostar.commands import Command, decode_request
from robostar.errors import FieldError, MalformedAnswerError, RobostarError
from robostar.protocol.frame import (
    ETX,
    MAX_PACKET,
    STX,
    Control,
    CorruptPacket,
    FrameDecoder,
    FrameEvent,
    Packet,
    lrc,
)
from robostar.protocol.link import (
    MAX_RESENDS,
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    HostLink,
    Ignored,
    LinkEvent,
    PeerMovedOn,
    RequestReceived,
    State,
    UploadPacketReceived,
    UploadReady,
)

__all__ = [
    "KnownIssue",
    "Violation",
    "check_answer",
    "check_controller_link",
    "check_frames",
    "check_host_link",
    "check_request",
    "check_resync",
    "split",
]

_MAX_DATA = MAX_PACKET - 3
_LINK_EVENTS = (
    AnswerReceived,
    UploadReady,
    ExchangeComplete,
    ExchangeFailed,
    RequestReceived,
    UploadPacketReceived,
    PeerMovedOn,
    Ignored,
)
_HOST_WAITS_FOR_APP = frozenset((State.IDLE, State.UPLOAD_READY))
_CONTROLLER_WAITS_FOR_APP = frozenset(
    (State.LISTEN, State.HANDLING, State.WORKING, State.UPLOAD_HANDLING)
)


class Violation(AssertionError):
    """robostar broke one of its promises on this input."""


class KnownIssue(Violation):
    """A violation of a bug already recorded (a strict-xfail regression test and
    docs/reliability.md name it); ``key`` says which. The long runs count these apart, so that
    one known bug does not stop them or hide a new one."""

    def __init__(self, key: str, message: str) -> None:
        self.key = key
        super().__init__(f"[known: {key}] {message}")


def split(stream: bytes, cuts: Sequence[int]) -> list[bytes]:
    """``stream`` cut at the given offsets (taken modulo its length; repeats allowed)."""
    if not stream:
        return [b""]
    points = sorted({cut % len(stream) for cut in cuts} | {0, len(stream)})
    return [stream[a:b] for a, b in itertools.pairwise(points)]


# -- frame decoder -----------------------------------------------------------------------------
def _feed(chunks: Sequence[bytes]) -> tuple[list[FrameEvent], FrameDecoder]:
    decoder = FrameDecoder()
    events: list[FrameEvent] = []
    for chunk in chunks:
        try:
            events += decoder.feed(chunk)
        except Exception as exc:
            raise Violation(f"FrameDecoder.feed raised {exc!r} on {chunk!r}") from exc
        if decoder.pending > _MAX_DATA + 1:
            raise Violation(f"decoder holds {decoder.pending} bytes, over one packet")
    return events, decoder


def _check_event(event: FrameEvent) -> None:
    if isinstance(event, Packet):
        data = event.data
        if STX in data or ETX in data or len(data) > _MAX_DATA:
            raise Violation(f"a Packet holds framing bytes or is too long: {data!r}")
    elif isinstance(event, CorruptPacket):
        if not event.raw or event.raw[0] != STX:
            raise Violation(f"a CorruptPacket does not start with STX: {event.raw!r}")
    elif not isinstance(event, Control):
        raise Violation(f"FrameDecoder yielded {event!r}")


def check_frames(stream: bytes, cuts: Sequence[int] = ()) -> list[FrameEvent]:
    """Decode ``stream`` whole and in pieces: the same well-formed events either way.

    Every Packet has a good LRC: it is re-checked against the stream it came from, so a decoder
    that let a damaged packet through would be caught here.
    """
    whole, _ = _feed([stream])
    pieces, _ = _feed(split(stream, cuts))
    if whole != pieces:
        raise Violation(f"events depend on the split: {whole!r} != {pieces!r}")
    for event in whole:
        _check_event(event)
        if isinstance(event, Packet):
            check = lrc(event.data)
            framed = bytes((STX, *event.data, ETX))
            if framed + bytes((check,)) not in stream and not (
                check == 0 and framed + bytes((ETX,)) in stream
            ):
                raise Violation(f"Packet {event.data!r} has no good LRC in the stream")
    return whole


_OVERLONG_RAW = MAX_PACKET - 1
"""STX and 248 data bytes: the shortest frame that is over the limit."""


def check_resync(garbage: bytes, first: bytes, second: bytes, cuts: Sequence[int] = ()) -> None:
    """After any garbage, the decoder finds good packets again at once.

    ``first`` and ``second`` are framed packets (``encode_packet`` output). The second is always
    decoded. The first may be lost only when the garbage ended inside a frame with its ETX (the
    byte after an ETX is the LRC whatever its value, so the first packet's STX is eaten).
    """
    decoder = FrameDecoder()
    for chunk in split(garbage, cuts):
        decoder.feed(chunk)
    events = decoder.feed(first + second)
    packets = [e.data for e in events if isinstance(e, Packet)]
    want_second = second[1:-2]
    want_first = first[1:-2]
    if not packets or packets[-1] != want_second:
        raise Violation(f"not resynced after {garbage!r}: second packet lost, got {events!r}")
    if want_first not in packets and not garbage.endswith(bytes((ETX,))):
        raise Violation(f"not resynced after {garbage!r}: first packet lost, got {events!r}")


# -- answer and request decoders -------------------------------------------------------------
def check_answer(command: Command[Any], packets: Sequence[bytes]) -> str:
    """``decode_answer`` on any packets returns or raises a typed error, nothing else.

    Returns ``"ok"`` or the error's class name, for the statistics.
    """
    try:
        command.decode_answer(packets)
    except (MalformedAnswerError, FieldError) as exc:
        return type(exc).__name__
    except Exception as exc:
        raise Violation(
            f"{type(command).__name__}.decode_answer({list(packets)!r}) raised {exc!r}"
        ) from exc
    return "ok"


def check_request(data: bytes) -> str:
    """``decode_request`` (the simulator's first step) on any data: a command or a FieldError
    carrying an answer flag. A decoded request must encode back to bytes it decodes from."""
    try:
        command = decode_request(data)
    except FieldError as exc:
        if exc.flag not in (0x31, 0x32, 0x33):
            raise Violation(f"decode_request({data!r}): FieldError with flag {exc.flag!r}") from exc
        return "FieldError"
    except Exception as exc:
        raise Violation(f"decode_request({data!r}) raised {exc!r}") from exc
    try:
        again = decode_request(command.encode())
    except RobostarError as exc:
        # Receivers are lenient (either padding, a name's case kept as sent); the command the
        # controller decoded must still be one a host could have sent.
        raise Violation(f"{command!r} decoded from {data!r} does not re-encode: {exc!r}") from exc
    if again != command:
        raise Violation(f"{data!r} -> {command!r} -> {again!r}: not stable")
    return type(command).__name__


# -- link machines ---------------------------------------------------------------------------
def _link_call(what: str, call: Any, *args: Any) -> list[LinkEvent]:
    try:
        events: list[LinkEvent] = call(*args)
    except Exception as exc:
        raise Violation(f"{what} raised {exc!r}") from exc
    for event in events:
        if not isinstance(event, _LINK_EVENTS):
            raise Violation(f"{what} produced {event!r}")
    return events


def _check_output(out: bytes, budget: int) -> None:
    if len(out) > budget:
        raise Violation(f"link wrote {len(out)} bytes for one input (budget {budget})")
    for event in FrameDecoder().feed(out):
        if isinstance(event, CorruptPacket):
            raise Violation(f"link wrote a damaged frame {event.raw!r}")


def check_host_link(request: bytes, command: Command[Any], chunks: Sequence[bytes]) -> State:
    """A host exchange fed any bytes: typed events only, well-formed output, and never a wait
    without a timer; its timers then always bring it back to idle."""
    link = HostLink(timeout=1.0, resend_gap=0.1)
    now = 0.0
    _link_call("send_request", link.send_request, request, command.SHAPE, now)
    link.data_to_send()
    for chunk in chunks:
        now += 0.05
        _link_call("receive_data", link.receive_data, chunk, now)
        _check_output(link.data_to_send(), MAX_PACKET * (len(chunk) + 1))
        if link.state is State.UPLOAD_READY:
            _link_call("send_upload_end", link.send_upload_end, now)
            link.data_to_send()
        if link.state not in _HOST_WAITS_FOR_APP and link.next_deadline() is None:
            raise Violation(f"host waits in {link.state} with no timer")
    # Its timeout ends the exchange; a quiet gap after the RST it sends may follow.
    for _ in range(3):
        deadline = link.next_deadline()
        if deadline is None:
            break
        _link_call("handle_timeout", link.handle_timeout, deadline)
        link.data_to_send()
    if not link.idle:
        raise Violation(f"host still in {link.state} after its timeouts")
    return link.state


def check_controller_link(chunks: Sequence[bytes], answers: Sequence[bytes]) -> State:
    """A controller fed any bytes, answering every request with ``answers``: typed events,
    well-formed output, timers while it waits for the host, back to LISTEN after its resends."""
    link = ControllerLink(timeout=1.0)
    now = 0.0
    for chunk in chunks:
        now += 0.05
        _link_call("receive_data", link.receive_data, chunk, now)
        _check_output(link.data_to_send(), MAX_PACKET * (len(chunk) + 1))
        if link.state in (State.HANDLING, State.UPLOAD_HANDLING):
            _link_call("send_answer", link.send_answer, list(answers), After.DONE, now)
            link.data_to_send()
        if link.state not in _CONTROLLER_WAITS_FOR_APP and link.next_deadline() is None:
            raise Violation(f"controller waits in {link.state} with no timer")
    for _ in range(MAX_RESENDS + 1):
        deadline = link.next_deadline()
        if deadline is None:
            break
        _link_call("handle_timeout", link.handle_timeout, deadline)
        link.data_to_send()
    if link.state not in _CONTROLLER_WAITS_FOR_APP:
        raise Violation(f"controller still in {link.state} after its resends")
    return link.state
