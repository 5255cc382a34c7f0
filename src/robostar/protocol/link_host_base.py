"""What every part of the host's link holds: the state of :class:`HostLink
<robostar.protocol.link_host.HostLink>` declared once, for its parts in modules of their own
(``link_resync``, ``link_fence``, ``link_timers``, ``link_fast``), which ``HostLink`` joins."""

from __future__ import annotations

from robostar.protocol.frame import ACK
from robostar.protocol.link_base import Link
from robostar.protocol.link_events import Fence
from robostar.protocol.packets import Shape

_Held = tuple[bytes, Shape, bool, int | None, bool]
"""A request waiting to go out (behind a fence, or a resync gap): its data, shape, ``once``,
``max_packets`` and ``distinct``, as :meth:`HostLink.send_request` took them."""


class HostLinkBase(Link):
    """The host link's state (set in ``HostLink.__init__``) and the handlers its parts call."""

    resync_gap: float
    resend_grace: float
    peer_resend_after: float
    max_wait: float
    abort_gap: float
    shape: Shape
    fences: tuple[Fence, ...]
    _pending_shape: Shape
    _pending_once: bool
    _pending_max: int | None
    _pending_distinct: bool
    _abandoned: dict[bytes, None]
    _fence: Fence | None
    _fenced: _Held | None
    _given_up_request: bytes
    _retry_next: bool
    _deferred: _Held | None
    _request_at: float
    _resync_until: float
    _limit_at: float | None
    _max_packets: int
    _packets: int
    _distinct: bool
    _copies: int
    _copies_of: int
    _progress_by: float | None
    _bytes: int
    _maybe_answer: bytes
    _last_reply: bytes
    _aborting: bool
    _quiet_at: float
    _stop_at: float | None
    _stop_early: bool
    _request_data: bytes | None
    _request_frame: bytes
    _clean_read: bytes
    _clean_packet: bytes

    def _ack(self, data: bytes) -> None:
        self._out.append(ACK)
        self._last_received = data
        self._last_ack_at = self._now

    def _h_send_request(self, data: bytes) -> None:
        raise NotImplementedError

    def _is_resend(self, data: bytes, now: float) -> bool:
        raise NotImplementedError
