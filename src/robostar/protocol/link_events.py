"""What the link reports to its application: the events each call returns, and the fence read."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from robostar.errors import LinkRuleError
from robostar.protocol.link_table import FailReason, State


@dataclass(frozen=True, slots=True)
class AnswerReceived:
    """Host: an answer packet of the current exchange (already ACKed where the rules say)."""

    data: bytes
    flag: int
    final: bool


@dataclass(frozen=True, slots=True)
class UploadReady:
    """Host, FB: the controller accepted the last packet; send the next line or the end."""

    data: bytes


@dataclass(frozen=True, slots=True)
class ExchangeComplete:
    """The exchange ended as the rules say (error flags included)."""


@dataclass(frozen=True, slots=True)
class ExchangeFailed:
    """The exchange ended abnormally; ``error`` is set for a rule break."""

    reason: FailReason
    state: State
    detail: str = ""
    error: LinkRuleError | None = None


@dataclass(frozen=True, slots=True)
class RequestReceived:
    """Controller: a request packet; answer it with :meth:`ControllerLink.send_answer`."""

    data: bytes


@dataclass(frozen=True, slots=True)
class UploadPacketReceived:
    """Controller, FB: a content packet (``end`` False) or the closing 0x34 (``end`` True)."""

    data: bytes
    end: bool


@dataclass(frozen=True, slots=True)
class PeerMovedOn:
    """Controller, in the application's turn (:data:`APP_TURN`): a read brought an RST or a
    packet, so the host has given the exchange up while the application still works on it.

    The input is held as any input in the turn, and the application's answer will not be sent
    (``Link._peer_moved_on``); this says so at once, so that the application can drop work
    nobody waits for any more. Reported once a turn, for input read after the turn began (what
    came in the same read as the request that started it is taken in order after the answer,
    as ever)."""

    state: State


@dataclass(frozen=True, slots=True)
class Ignored:
    """Something arrived that the rules say to drop (a stray ACK, a resent packet); for traces."""

    what: str
    state: State


@dataclass(frozen=True, slots=True)
class Fence:
    """A read the host sends before its next request after an abandoned exchange, whose
    answer no other request's answer can be taken for (``accepts``). Whatever arrives before
    that answer belongs to an exchange the host gave up, and is dropped; after it, the line
    holds nothing old (the controller answers in order), and the request goes out."""

    request: bytes
    """The read's packet data, ``FF G1 G2 params``."""
    accepts: Callable[[bytes], bool]
    """True for an answer packet (flag 0x30) that only this read can have."""

    @property
    def code(self) -> bytes:
        return self.request[1:3]


LinkEvent = (
    AnswerReceived
    | UploadReady
    | ExchangeComplete
    | ExchangeFailed
    | RequestReceived
    | UploadPacketReceived
    | PeerMovedOn
    | Ignored
)

_COMPLETE = ExchangeComplete()
"""ExchangeComplete has no fields: every one equals every other, so one will do."""
