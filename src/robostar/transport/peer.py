"""The byte-peer interface: an in-process far end (simulator, fault injector) of a line.

A peer is driven like the sans-IO core, with names of its own (a link's `receive_data` returns
events, a peer's `feed` returns nothing; a peer's `output` advances its clock too): the
transport feeds it the bytes the host wrote with the current time, and asks it for the bytes to
deliver. It never blocks and owns no thread.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["BytePeer"]


@runtime_checkable
class BytePeer(Protocol):
    """The far end of an in-process line. ``now`` is monotonic seconds (``time.monotonic()``)."""

    def feed(self, data: bytes, now: float) -> None:
        """Bytes the host wrote."""

    def output(self, now: float) -> bytes:
        """Advance to ``now`` and return the bytes the peer has for the host (may be empty)."""

    def next_deadline(self) -> float | None:
        """When :meth:`output` should be called again even if the host writes nothing."""
