"""One exchange on the link as a step object: no I/O and no clock, shared by both clients.

An :class:`Exchange` wraps :class:`~robostar.protocol.link.HostLink` for one command: it encodes
the request (so a bad field is refused before a byte is written), collects the answer packets,
feeds FB's lines as the controller asks for them, and ends with an :class:`Outcome`. The driver
around it only moves bytes and waits until :meth:`Exchange.deadline`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, cast

from robostar.commands.base import Command, Shape, split_answer
from robostar.commands.files import DownloadFile, UploadFile
from robostar.errors import LinkRuleError
from robostar.protocol.fields import FLAG_FAILED, FLAG_REJECTED, FLAG_UNSUPPORTED, FileName
from robostar.protocol.link import (
    AnswerReceived,
    ExchangeComplete,
    ExchangeFailed,
    HostLink,
    LinkEvent,
    UploadReady,
)

__all__ = ["ERROR_FLAGS", "Exchange", "Outcome", "Progress", "is_upload"]

ERROR_FLAGS = frozenset((FLAG_REJECTED, FLAG_FAILED, FLAG_UNSUPPORTED))

Progress = Callable[[int, int | None], None]
"""Called as ``progress(done, total)``: packets received (downloads) or lines the controller
accepted (uploads), and the total when it is known (``None`` otherwise)."""


@dataclass(frozen=True, slots=True)
class Outcome:
    """How one exchange ended.

    ``packets`` are the answer packets in order (for FB: the controller's replies). ``flag`` is
    the error flag (0x31-0x33) if the controller answered with one; ``failure`` is set when the
    link gave up (timeout, RST, NAKs, a broken rule). ``lines_sent`` counts FB lines the
    controller accepted.
    """

    packets: tuple[bytes, ...]
    flag: int | None = None
    failure: ExchangeFailed | None = None
    lines_sent: int = 0


def _job_total(command: DownloadFile, first: bytes) -> int | None:
    """FA of a JOB file: the first packet announces the step count, so the packet count is
    known (announcement + steps + END). A PNT file announces its highest point number, which
    says nothing of how many points it holds."""
    file = command.file
    if not (isinstance(file, FileName) and file.is_job):
        return None
    text = split_answer(first).body.decode("ascii", "replace").strip()
    return int(text) + 2 if text.isdigit() else None


def is_upload(command: Command[Any]) -> bool:
    """Is ``command`` an FB upload (the one command of that shape)?"""
    return command.SHAPE is Shape.UPLOAD


_NO_LINES: tuple[bytes, ...] = ()


class Exchange:
    """Runs one command's exchange on ``link``; the caller moves the bytes.

    Use: :meth:`start`, then loop writing :meth:`output` and feeding :meth:`receive` (bytes) or
    :meth:`tick` (nothing arrived by :meth:`deadline`) until :attr:`done`; read :meth:`outcome`.
    """

    # One is made per exchange: slots make it, and every attribute read on the way, cheaper.
    __slots__ = (
        "_accepted",
        "_bodies",
        "_download",
        "_failure",
        "_flag",
        "_next_line",
        "_packets",
        "_single",
        "_total",
        "command",
        "done",
        "link",
        "progress",
        "request",
        "upload",
    )

    def __init__(
        self,
        link: HostLink,
        command: Command[Any],
        progress: Progress | None = None,
    ) -> None:
        self.link = link
        self.command = command
        self.progress = progress
        # Encoding checks every field; a bad one raises FieldError before anything is written.
        self.request = command.encode()
        shape = command.SHAPE
        upload = self.upload = shape is Shape.UPLOAD
        # A SINGLE exchange's clean answer is taken in one step (HostLink.receive_clean_answer).
        self._single = shape is Shape.SINGLE
        # FA (MULTI) counts its packets against the total its first packet announces.
        self._download = shape is Shape.MULTI and isinstance(command, DownloadFile)
        self._bodies: Sequence[bytes] = (
            cast(UploadFile, command).upload_bodies() if upload else _NO_LINES
        )
        self._next_line = 0
        self._accepted = 0
        self._packets: list[bytes] = []
        self._flag: int | None = None
        self._failure: ExchangeFailed | None = None
        self._total = len(self._bodies) if upload else None
        self.done = False

    def start(self, now: float) -> None:
        """Send the request (a state change at most once more after a NAK; an answer cut at
        what the command can carry)."""
        command = self.command
        if command.DISTINCT_PACKETS:
            events = self.link.send_request(
                self.request,
                command.SHAPE,
                now,
                once=command.CHANGES_STATE,
                max_packets=command.MAX_PACKETS,
                distinct=True,
            )
        else:  # the usual request, without the rare flag (every request passes here)
            events = self.link.send_request(
                self.request,
                command.SHAPE,
                now,
                once=command.CHANGES_STATE,
                max_packets=command.MAX_PACKETS,
            )
        if events:
            self._handle(events, now)

    def output(self) -> bytes:
        """Bytes to write now."""
        return self.link.data_to_send()

    def deadline(self) -> float:
        """When :meth:`tick` is due if nothing arrives (the link always has a timer here)."""
        deadline = self.link.next_deadline()
        if deadline is None:
            raise LinkRuleError("host", self.link.state.value, "wait", "no timer while waiting")
        return deadline

    def receive(self, data: bytes, now: float) -> None:
        if self._single and self._took_clean_answer(data, now):
            return
        self._handle(self.link.receive_data(data, now), now)

    def _took_clean_answer(self, data: bytes, now: float) -> bool:
        """A SINGLE exchange's clean answer, in one step (HostLink.receive_clean_answer); False
        when the rules must see ``data`` (then nothing changed)."""
        packet = self.link.receive_clean_answer(data, now)
        if packet is None:
            return False
        # What _handle does with the events receive_data would have returned (AnswerReceived
        # with flag 0x30, then ExchangeComplete).
        self._packets.append(packet)
        if self.progress is not None:  # what _answer_progress does for a SINGLE exchange
            self.progress(1, None)
        self.done = True
        return True

    def answer_at_once(self, data: bytes, now: float) -> bytes | None:
        """Take a SINGLE exchange's clean answer where it lands (an
        :class:`~robostar.transport.base.Answerer`): when ``data`` is exactly that answer the
        exchange is done and this returns the ACK to write at once; otherwise None, nothing
        changed (give ``data`` to :meth:`receive`). Only for an exchange without progress
        (its callback must not run inside a transport's)."""
        if self._single and self._took_clean_answer(data, now):
            return self.link.data_to_send()
        return None

    def tick(self, now: float) -> None:
        self._handle(self.link.handle_timeout(now), now)

    def abort(self, now: float) -> None:
        """End the exchange with RST (the caller gave up: Ctrl-C, a lost port)."""
        self._handle(self.link.abort(now), now)
        self.done = True

    def outcome(self) -> Outcome:
        return Outcome(tuple(self._packets), self._flag, self._failure, self._accepted)

    def answer(self) -> tuple[bytes, ...] | None:
        """The answer packets when the exchange ended with an answer the rules would only
        decode (no failure, no error flag, not an upload); otherwise None (then the rules
        look at :meth:`outcome`)."""
        if self._failure is None and self._flag is None and not self.upload:
            return tuple(self._packets)
        return None

    # -- events ----------------------------------------------------------------------------
    def _handle(self, events: list[LinkEvent], now: float) -> None:
        for event in events:
            if isinstance(event, AnswerReceived):
                self._packets.append(event.data)
                if event.flag in ERROR_FLAGS:
                    self._flag = event.flag
                else:
                    self._answer_progress(event.data)
            elif isinstance(event, UploadReady):
                self._packets.append(event.data)
                self._send_next_line(now)
            elif isinstance(event, ExchangeComplete):
                self.done = True
            elif isinstance(event, ExchangeFailed):
                self._failure = event
                self.done = True

    def _answer_progress(self, data: bytes) -> None:
        if self._download and len(self._packets) == 1:
            self._total = _job_total(cast(DownloadFile, self.command), data)
        if self.progress is not None:
            self.progress(len(self._packets), self._total)

    def _send_next_line(self, now: float) -> None:
        # The first reply accepts the request; each later one accepts the line sent before it.
        if self._next_line:
            self._accepted = self._next_line
            if self.progress is not None:
                self.progress(self._accepted, self._total)
        if self._next_line < len(self._bodies):
            body = self._bodies[self._next_line]
            self._next_line += 1
            self._handle(self.link.send_upload_line(body, now), now)
        else:
            self._handle(self.link.send_upload_end(now), now)
