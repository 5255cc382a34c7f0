"""The manual's resend limit, held against a controller that repeats a packet without end.

A controller resends an unacknowledged packet at most ``MAX_RESENDS`` times; a further copy
is a broken rule: the host sends RST, the call raises LinkRuleError, and the line is clean for
the next call. Commands whose answer packets are all different (FD's files, FH's records) take
every copy of the packet just ACKed for a resend, however soon it comes, so a repeating peer
is stopped after a few copies instead of filling the answer to the command's cap.
"""

from __future__ import annotations

import pytest

from robostar.commands.files import ListFiles, ReadAlarmHistory
from robostar.errors import LinkRuleError
from robostar.protocol.frame import encode_packet
from robostar.protocol.link import MAX_RESENDS
from robostar.types import FileRecord

from .test_client_hostile_controller import STATUS, Scripted, client

pytestmark = pytest.mark.timeout(60)

FILE = FileRecord(1, "RS.JOB", 27, 200)


def test_a_controller_resending_fds_first_record_after_every_ack_is_stopped() -> None:
    # The first record again 0.5 s after every ACK: sooner than a controller's resend, so
    # without the limit each copy passed for the next file, up to FD's 403 packets (minutes).
    first = encode_packet(ListFiles(1).encode_answer((FILE,))[0])
    peer = Scripted(lambda data, n: [(0.0, first)] if n == 1 else [(0.0, STATUS)])
    peer.on_ack = lambda n: [(0.5, first)]
    with client(peer, timeout=2.0) as robot:
        with pytest.raises(LinkRuleError, match="resends at most 3 times"):
            robot.list_files(1)
        # the record, then each of the resends a controller may make, ACKed; the next copy RST
        assert peer.acks == 1 + MAX_RESENDS
        assert peer.resets == 1
        peer.on_ack = lambda n: ()
        assert robot.status()[0].ready  # the line is clean again


def test_fds_and_fhs_packets_are_all_different() -> None:
    assert ListFiles.DISTINCT_PACKETS and ReadAlarmHistory.DISTINCT_PACKETS


def test_a_resent_record_within_the_limit_is_taken_once() -> None:
    # The record's ACK is lost twice (the controller resends it twice), then the answer ends.
    packets = [encode_packet(p) for p in ListFiles(1).encode_answer((FILE,))]
    peer = Scripted(lambda data, n: [(0.0, packets[0])])
    peer.on_ack = lambda n: [(0.1, packets[0])] if n <= 2 else [(0.0, packets[1])]
    with client(peer, timeout=2.0) as robot:
        assert robot.list_files(1) == (FILE,)
    assert peer.resets == 0
