"""FD, FH and KE against a controller that never ends its answer: each is cut at what the
command can carry, not at the link's general 10,002 packets.

The caps (``MAX_PACKETS``) come from the manual: FD lists a channel's JOB files (JOB numbers
0-200) and their PNT files (403 packets with END); FH sends a header and ten pages of ten
records (102); KE's index is two digits, and each of its 99 groups may take up to ten packets
(991). The largest legitimate answer of each still comes through whole.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import pytest

from robostar import Client
from robostar.commands.base import Command
from robostar.commands.files import ListFiles, ReadAlarmHistory
from robostar.commands.system import ReadParameters
from robostar.errors import AnswerTooLongError
from robostar.protocol.frame import encode_packet
from robostar.protocol.link import MAX_MULTI_PACKETS
from robostar.types import AlarmRecord, FileRecord

from .test_client_hostile_controller import STATUS, Scripted, client

pytestmark = pytest.mark.timeout(60)

FILE = FileRecord(1, "RS.JOB", 27, 200)
ALARM = AlarmRecord(1, 1, 3, 4, 5, 6, 1, "T/P Emergency", "", 12)
PARAMETER = "LENG: 350.000 250.000"


def _list_files(robot: Client) -> Any:
    return robot.list_files(1)


def _alarm_history(robot: Client) -> Any:
    return robot.alarm_history()


def _parameters(robot: Client) -> Any:
    return robot.parameters(1)


def _answer(command: Command[Any], count: int) -> list[bytes]:
    """A legitimate answer of ``command`` holding ``count`` packets, END included. FD's and
    FH's packets all differ (a copy of one is a resend: test_client_resend_limit.py)."""
    if isinstance(command, ListFiles):
        files = [replace(FILE, name=f"R{n:04d}.JOB") for n in range(count - 1)]
        return command.encode_answer(tuple(files))
    if isinstance(command, ReadAlarmHistory):
        alarms = [replace(ALARM, page=n // 10, index=n % 10) for n in range(count - 2)]
        return command.encode_answer(tuple(alarms))
    assert isinstance(command, ReadParameters)
    return command.encode_answer((PARAMETER,) * (count - 1))


CASES: list[tuple[Command[Any], Callable[[Client], Any], int]] = [
    (ListFiles(1), _list_files, 403),
    (ReadAlarmHistory(), _alarm_history, 102),
    (ReadParameters(1), _parameters, 991),
]
IDS = ["FD", "FH", "KE"]


@pytest.mark.parametrize(("command", "call", "cap"), CASES, ids=IDS)
def test_the_caps_are_the_manuals(command: Command[Any], call: object, cap: int) -> None:
    assert command.MAX_PACKETS == cap < MAX_MULTI_PACKETS


@pytest.mark.parametrize(("command", "call", "cap"), CASES, ids=IDS)
def test_an_endless_answer_is_cut_at_what_the_command_can_carry(
    command: Command[Any], call: Callable[[Client], Any], cap: int
) -> None:
    # A hostile controller: a valid first packet, then another valid packet after every ACK,
    # never END. Before the caps, it ran to the link's general 10,002 packets.
    packets = [encode_packet(p) for p in _answer(command, cap + 2)[:-1]]
    peer = Scripted(lambda data, n: [(0.0, packets[0])] if n == 1 else [(0.0, STATUS)])
    peer.on_ack = lambda n: [(0.0, packets[min(n, len(packets) - 1)])]
    with client(peer) as robot:
        with pytest.raises(AnswerTooLongError, match=f"more than {cap} packets"):
            call(robot)
        assert peer.acks == cap
        assert peer.resets == 1
        peer.on_ack = lambda n: ()
        assert robot.status()[0].ready  # the line is clean again


@pytest.mark.parametrize(("command", "call", "cap"), CASES, ids=IDS)
def test_the_largest_legitimate_answer_comes_through(
    command: Command[Any], call: Callable[[Client], Any], cap: int
) -> None:
    packets = [encode_packet(p) for p in _answer(command, cap)]
    peer = Scripted(lambda data, n: [(0.0, packets[0])])
    peer.on_ack = lambda n: [(0.0, packets[n])] if n < len(packets) else []
    with client(peer) as robot:
        result = call(robot)
    assert len(result) == cap - (2 if isinstance(command, ReadAlarmHistory) else 1)
    assert peer.resets == 0
