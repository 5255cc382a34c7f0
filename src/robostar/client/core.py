"""What the blocking and the asyncio client share: settings, the link, the trace, and the
exchange loop itself, as a plan of line I/O steps (:class:`Write`, :class:`Read`) that each
client performs its own way."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from robostar.client import args
from robostar.client.driver import FENCES, Policy
from robostar.client.exchange import Exchange
from robostar.client.surface import PlanHelpers
from robostar.client.trace import TraceTarget, WireTrace
from robostar.commands.base import Command
from robostar.commands.files import UploadFile
from robostar.errors import OutcomeUnknownError, PortError, UploadIncompleteError, UsageError
from robostar.protocol.frame import MAX_PACKET
from robostar.protocol.link import HostLink
from robostar.transport import AsyncTransport, Transport

__all__ = ["DRAIN_READS", "KEEPALIVE_LIMIT", "ClientBase", "Settings"]

KEEPALIVE_LIMIT = 0.5
"""The manual: a jog stops unless a BF comes within 500 ms of the last one."""
DRAIN_READS = 32
"""Most reads of stray input before a request (a line that never stops talking is noise)."""


@dataclass(frozen=True, slots=True)
class Settings:
    """A client's settings, checked.

    ``timeout``: reply timeout (s); ``retries``: resends of a read-only command after a lost
    answer; ``poll_interval``: status reads while waiting (s); ``keepalive``: BF interval of a
    jog (s, under 0.5); ``reconnect``: reopen a lost line on the next call;
    ``controller_timeout``: the controller's own resend timeout (None: the same as ``timeout``).
    """

    timeout: float = 2.0
    retries: int = 1
    poll_interval: float = 0.1
    keepalive: float = 0.2
    reconnect: bool = False
    controller_timeout: float | None = None

    def __post_init__(self) -> None:
        args.positive(self.timeout, "timeout")
        args.non_negative_int(self.retries, "retries")
        args.positive(self.poll_interval, "poll_interval")
        check_keepalive(self.keepalive, "keepalive")
        args.boolean(self.reconnect, "reconnect")
        if self.controller_timeout is not None:
            args.positive(self.controller_timeout, "controller_timeout")


def check_keepalive(value: object, name: str) -> float:
    interval = args.positive(value, name)
    if interval >= KEEPALIVE_LIMIT:
        raise UsageError(f"{name}: {interval:g} s is not under the 0.5 s the controller allows")
    return interval


class ClientBase(PlanHelpers):
    """The state both clients keep; the subclasses add the waiting."""

    transport: Transport | AsyncTransport

    @property
    def url(self) -> str:
        return self.transport.url

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.url}>"

    def _setup(self, settings: Settings, trace: TraceTarget | None) -> None:
        self.settings = settings
        self.poll_interval = settings.poll_interval
        self._policy = Policy(settings.timeout, settings.retries)
        self._trace = WireTrace(trace) if trace is not None else None
        self._link = self._new_link()
        self._opened = False
        self._closed = False

    @property
    def timeout(self) -> float:
        return self.settings.timeout

    def _new_link(self) -> HostLink:
        # After an RST the line must stay quiet for a whole reply timeout before the next
        # request: an answer a device server held back cannot then pass for the next one's.
        # After our own abort the same holds for every request but a stop (CF, CD, CI, BG:
        # a stop pre-empting a transfer), which may go out once the line has been quiet for
        # one packet's time at the line's speed (at least 50 ms): the controller stops at
        # the RST, and a stop's answer, a bare flag, is told from stale data (HostLink).
        timeout = self.settings.timeout
        settings = getattr(self.transport, "settings", None)
        baud = getattr(settings, "baudrate", 0)
        packet_time = MAX_PACKET * 10 / baud if isinstance(baud, int) and baud > 0 else 0.0
        return HostLink(
            timeout=timeout,
            resync_gap=timeout,
            abort_gap=max(0.05, packet_time),
            peer_resend_after=self.settings.controller_timeout,
            fences=FENCES,
        )

    def _check_may_open(self) -> None:
        """Raise unless the line may be (re)opened now: not closed, and not lost without
        ``reconnect``."""
        if self._closed:
            raise PortError(f"{self.url}: the client is closed")
        if self._opened and not self.settings.reconnect:
            raise PortError(
                f"{self.url}: the connection was lost; make a new client, or pass "
                "reconnect=True to reopen it on the next call"
            )

    def _line_lost(self, command: Command[Any], exc: PortError, written: bool) -> Exception:
        """The error for a line lost mid-exchange: the request may have reached the controller,
        so a state-changing command's outcome is unknown."""
        self._link = self._new_link()
        if written and isinstance(command, UploadFile):
            # An upload cut off mid-way is never complete; the caller may upload it again.
            return UploadIncompleteError(f"FB {command.file}: the line was lost: {exc}")
        if written and command.CHANGES_STATE:
            return OutcomeUnknownError(command.CODE, f"the line was lost: {exc}")
        return exc

    # -- the line's sans-IO steps both clients take around an exchange ------------------------
    def _stray_input(self, data: bytes) -> None:
        """Hand input read between exchanges to the idle link (it ACKs a resent answer)."""
        self._traced_received(data)
        self._link.receive_data(data, time.monotonic())

    def _link_output(self) -> bytes:
        """What the idle link has to send now (b"": nothing), traced."""
        out = self._link.data_to_send()
        if out:
            self._traced_sent(out)
        return out

    def _abort_output(self, exchange: Exchange) -> bytes:
        """End ``exchange`` with RST (Ctrl-C, a cancelled task, a callback's error): the bytes
        to write, traced; b"" when there are none or the line is closed."""
        exchange.abort(time.monotonic())
        out = exchange.output()
        if not out or not self.transport.is_open:
            return b""
        self._traced_sent(out)
        return out

    def _traced_sent(self, data: bytes) -> None:
        if self._trace is not None:
            self._trace.sent(data)

    def _traced_received(self, data: bytes) -> None:
        if self._trace is not None:
            self._trace.received(data)

    def _close_trace(self) -> None:
        if self._trace is not None:
            self._trace.close()
