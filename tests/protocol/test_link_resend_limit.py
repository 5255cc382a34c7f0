"""The host link's resend limit in a multi-packet answer: a copy of a packet beyond the
manual's MAX_RESENDS is a broken rule, and the wait for the next new packet never outlasts
the moment a controller resending the last one would have given up.

Driven by hand with explicit ``now`` values; nothing sleeps.
"""

from __future__ import annotations

from robostar.protocol.frame import RST, encode_packet
from robostar.protocol.link import (
    MAX_RESENDS,
    ExchangeFailed,
    FailReason,
    HostLink,
    State,
)
from robostar.protocol.packets import Shape

AB = b"\xffAB"
ALARM = encode_packet(b"0E1153 : T/P Emergency       ")
BAD_LRC = bytes.fromhex("02 30 41 03 00")


def _failures(events: list[object]) -> list[ExchangeFailed]:
    return [event for event in events if isinstance(event, ExchangeFailed)]


def test_a_late_copy_beyond_the_resend_limit_is_a_broken_rule() -> None:
    host = HostLink(timeout=2.0)
    host.send_request(AB, Shape.MULTI, 0.0)
    host.data_to_send()
    host.receive_data(ALARM, 0.1)
    now = 0.1
    for _ in range(MAX_RESENDS):  # each late enough for a resend: ACKed again
        now += 1.9
        assert not _failures(host.receive_data(ALARM, now))
        assert host.state is State.WAIT_MORE
    now += 1.9
    (failure,) = _failures(host.receive_data(ALARM, now))
    assert failure.reason is FailReason.RULE
    assert "resends at most 3 times" in failure.detail
    assert host.data_to_send().endswith(bytes((RST,)))


def test_noise_between_resends_cannot_put_off_the_next_new_packet() -> None:
    # A record, then noise and late copies of it in turn: each restarted the wait. A
    # controller resending the record has given up after (MAX_RESENDS + 1) resend periods.
    host = HostLink(timeout=2.0, resend_grace=0.5)
    host.send_request(AB, Shape.MULTI, 0.0)
    host.receive_data(ALARM, 0.0)
    due = (MAX_RESENDS + 1) * 2.0 + 0.5
    events: list[object] = []
    for at, data in [(1.9, BAD_LRC), (3.8, ALARM), (6.2, BAD_LRC), (8.1, BAD_LRC)]:
        events += host.receive_data(data, at)
        deadline = host.next_deadline()
        assert deadline is not None and deadline <= due
    assert not _failures(events)
    (failure,) = _failures(host.handle_timeout(due))
    assert failure.reason is FailReason.TIMEOUT
    assert "no new packet" in failure.detail
