"""The fence: after an abandoned exchange, a read whose answer nothing else can be taken for goes
before the next request, and whatever arrives before its answer is dropped as old."""

from __future__ import annotations

from robostar.protocol.fields import FLAG_OK
from robostar.protocol.link_base import _flag_of
from robostar.protocol.link_events import Fence, Ignored
from robostar.protocol.link_host_base import HostLinkBase
from robostar.protocol.link_table import EARLY_CODES, State
from robostar.protocol.packets import Shape


class FenceRules(HostLinkBase):
    """Which requests wait behind a fence, which fence is sent, and its answer (WAIT_FENCE)."""

    def retry_next(self) -> None:
        """The next request is the application asking the same call again (a read whose
        answer was lost): if it is the request given up last, it needs no fence, since a late
        answer to it answers this call (see ``_needs_fence``)."""
        self._retry_next = True

    def _send_fence(self, data: bytes) -> None:
        """An exchange was given up since the last clean answer: its answer may still come.
        A fence read goes first; the request ``data`` waits behind it (stops never do)."""
        self._fenced = (
            data,
            self._pending_shape,
            self._pending_once,
            self._pending_max,
            self._pending_distinct,
        )
        fence = self._fence = self._pick_fence()
        self._pending_shape, self._pending_once = Shape.SINGLE, False
        self._pending_max, self._pending_distinct = None, False
        self._h_send_request(fence.request)  # no fence before it: one is open (_needs_fence)
        self.state = State.WAIT_FENCE

    def _pick_fence(self) -> Fence:
        """The first fence whose own read was not given up (its answer could be late too); if
        every one was, the one given up longest ago."""
        abandoned = self._abandoned
        for fence in self.fences:
            if fence.code not in abandoned:
                return fence
        order = list(abandoned)
        return min(self.fences, key=lambda fence: order.index(fence.code))

    def _h_fence_answer(self, data: bytes) -> None:
        self._good_packet()
        fence = self._fence
        assert fence is not None and self._fenced is not None
        if _flag_of(data) != FLAG_OK or not fence.accepts(data):
            # Sent before the fence's answer, so by an exchange we gave up: dropped, not ACKed
            # (the controller dropped that exchange at our RST, or at the fence's request).
            self._emit(Ignored("stale packet before the fence's answer (dropped)", self.state))
            return
        self._ack(data)
        self._abandoned.clear()
        self._fence = None
        fenced, self._fenced = self._fenced, None
        data, self._pending_shape, self._pending_once, self._pending_max = fenced[:4]
        self._pending_distinct = fenced[4]
        self._h_send_request(data)

    def _given_up(self) -> None:
        """This end gave up the request sent last (with its RST): its answer may still come."""
        request = self._request_data or b""  # the request sent last
        code = request[1:3]
        self._abandoned.pop(code, None)
        self._abandoned[code] = None
        self._given_up_request = request
        self._retry_next = False  # a retry_next() before this was for the request given up

    def _needs_fence(self, data: bytes) -> bool:
        """Must ``data`` wait behind a fence? When an exchange was given up since the last
        fence, unless ``data`` is a stop (never held back) or the application's retry of the
        very request given up, alone (a late answer of the first try answers the same call;
        the given-up mark stays, so the next other request or call is fenced)."""
        abandoned = self._abandoned
        if self._fence is not None or not self.fences or data[1:3] in EARLY_CODES:
            return False  # (a fence being sent is not fenced itself)
        retry, self._retry_next = self._retry_next, False
        return len(abandoned) > 1 or not (retry and data == self._given_up_request)
