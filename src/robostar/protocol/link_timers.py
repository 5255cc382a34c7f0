"""The host's timers: every timer of an exchange stays within the exchange's overall limit and a
multi-packet answer's progress deadline."""

from __future__ import annotations

from robostar.protocol.link_host_base import HostLinkBase
from robostar.protocol.link_table import _NOT_BUSY, State


class HostTimers(HostLinkBase):
    """Arming and extending the host's timer, clamped to the exchange's limits."""

    def _arm(self, seconds: float) -> None:
        # Link._arm, then _clamp, inline: every request and every answer arms a timer.
        deadline = self._now + seconds
        limit = self._limit_at
        if limit is not None and deadline > limit and self.state not in _NOT_BUSY:
            deadline = limit
        self._deadline = deadline

    def _extend(self, seconds: float) -> None:
        super()._extend(seconds)
        self._clamp()

    def _clamp(self) -> None:
        """No timer of an exchange runs past the exchange's overall limit, nor a multi-packet
        answer's wait past the moment its next new packet is due (``_progress_by``)."""
        limit = self._limit_at
        if limit is not None and self.busy and self._deadline is not None:
            self._deadline = min(self._deadline, limit)
        progress = self._progress_by
        if progress is not None and self.state is State.WAIT_MORE and self._deadline is not None:
            self._deadline = min(self._deadline, progress)
