"""The clean answer: an OK answer ending the SINGLE exchange waited on, accepted in one step
that the usual read takes straight from the line, with the memo of the last read's framing,
and that the answer handler (``HostLink._h_answer``) takes first for a packet the decoder
framed (:meth:`CleanAnswer.receive_clean_answer`, for both)."""

from __future__ import annotations

from robostar.protocol.fields import FLAG_OK
from robostar.protocol.frame import ACK, MAX_PACKET, Packet, lone_frame
from robostar.protocol.link_base import _RESEND_SHARE
from robostar.protocol.link_host_base import HostLinkBase
from robostar.protocol.link_table import State
from robostar.protocol.packets import Shape


class CleanAnswer(HostLinkBase):
    """HostLink.receive_clean_answer: the one accept step of a clean answer."""

    def receive_clean_answer(self, data: bytes | Packet, now: float) -> bytes | None:
        """The usual read of a single exchange, in one step: when ``data`` is exactly one
        whole frame with a good LRC (:func:`~robostar.protocol.frame.lone_frame`) holding an
        OK answer (flag 0x30; not one taken for the controller resending the answer ACKed
        last) to the SINGLE request this link waits on, with nothing held and no frame begun,
        the link does what :meth:`receive_data` does with it (ACK it, end the exchange) and
        returns the packet's data. The events :meth:`receive_data` would have returned are
        then exactly ``[AnswerReceived(packet, 0x30, final=True), ExchangeComplete()]``; none
        are made.

        Otherwise it returns None and has changed nothing: give the same bytes to
        :meth:`receive_data`, whose rules decide.

        ``data`` may also be a :class:`~robostar.protocol.frame.Packet` the decoder framed,
        taken in the order the line brought it: the answer handler's first step (it tells the
        events when the packet is taken). One accept step for both, in one function, told
        apart by the type the usual read tests anyway: the usual read pays for no second call.
        """
        if type(data) is not bytes:
            if (
                type(data) is not Packet
                or self.state is not State.WAIT_ANSWER
                or self.shape is not Shape.SINGLE
                or self._stop_early
            ):
                return None  # a read of another type (bytearray, memoryview): the rules'
            packet = data.data
            if self._backlog and packet == self._last_received:
                # A copy of the packet ACKed last with more held behind it: the handler's
                # rules tell a repeat sent without waiting from a resend.
                return None
        elif (
            self.state is not State.WAIT_ANSWER
            or self.shape is not Shape.SINGLE
            or self._backlog
            or not self.decoder.between_frames
            or self._stop_early
        ):
            return None
        elif data == self._clean_read:
            # The same bytes as the last clean answer (a poll answered alike): the same packet.
            packet = self._clean_packet
        else:
            found = lone_frame(data)
            if found is None:
                return None
            packet = self._clean_packet = found
            self._clean_read = data
        if (
            packet == self._last_received
            # _is_resend's timing test first, inline: every poll answered alike comes here,
            # and a copy sooner than the controller's resend is new data
            and now - self._last_ack_at >= _RESEND_SHARE * self.peer_resend_after
            and self._is_resend(packet, now)
        ):
            return None
        # The flag as _flag_of reads it: a leading FF is the dummy byte.
        offset = 1 if packet[:1] == b"\xff" else 0
        size = len(packet)
        if (
            size <= offset
            or packet[offset] != FLAG_OK
            or self._packets >= self._max_packets
            or self._bytes + size > self._max_packets * MAX_PACKET
        ):
            return None
        # Taken: the answer handler's steps for an OK answer ending a SINGLE exchange
        # (_good_packet, the count, _ack), then _finish's.
        self._now = now
        self._corrupt = 0
        self._packets += 1
        self._bytes += size
        self._out.append(ACK)
        self._last_received = packet
        self._last_ack_at = now
        self._limit_at = None
        self._deadline = None
        self.state = State.IDLE
        return packet
