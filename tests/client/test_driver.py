"""The command rules (retries, KD, typed errors, verified uploads) and the exchange step object.

``command_plan`` is driven by hand with made-up outcomes: no line, no clock. ``Exchange`` is
driven against a :class:`~robostar.protocol.link.ControllerLink` playing the controller.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robostar.client.driver import Policy, command_plan
from robostar.client.exchange import Exchange, Outcome
from robostar.commands.base import Command, make_answer
from robostar.commands.control import SetSpeed
from robostar.commands.files import DownloadFile, UploadFile, format_point_line
from robostar.commands.job import Servo
from robostar.commands.status import ReadPosition, ReadStatus
from robostar.commands.system import ReadLastError
from robostar.errors import (
    FieldError,
    FunctionFailedError,
    LinkResetError,
    LinkRuleError,
    MalformedAnswerError,
    NakLimitError,
    NotSupportedError,
    OutcomeUnknownError,
    RejectedError,
    ReplyTimeoutError,
    RobostarError,
    UploadIncompleteError,
)
from robostar.protocol.frame import ACK, encode_packet
from robostar.protocol.link import (
    After,
    ControllerLink,
    ExchangeFailed,
    FailReason,
    HostLink,
    RequestReceived,
    State,
    UploadPacketReceived,
)
from robostar.types import ChannelStatus, JobFile, Point

POLICY = Policy(timeout=0.5, retries=2)
STATUS_OK = make_answer(0x30, bytes((0x84, 0x84, 0x80)))


def ok(body: bytes = b"", *, dummy: bool = False) -> bytes:
    return make_answer(0x30, body, dummy=dummy)


def failed(reason: FailReason, state: State = State.WAIT_ANSWER, detail: str = "") -> Outcome:
    return Outcome((), failure=ExchangeFailed(reason, state, detail))


def drive(
    command: Command[Any], outcomes: Sequence[Outcome], policy: Policy = POLICY
) -> tuple[list[Command[Any]], Any]:
    """Run the plan, answering each request with the next outcome; (requests, result|error)."""
    plan = command_plan(command, policy)
    requests: list[Command[Any]] = []
    replies = iter(outcomes)
    try:
        request = next(plan)
        while True:
            requests.append(request)
            request = plan.send(next(replies))
    except StopIteration as stop:
        return requests, stop.value
    except RobostarError as exc:
        return requests, exc


# -- answers and flags -------------------------------------------------------------------------
def test_an_answer_is_decoded() -> None:
    requests, result = drive(ReadStatus(), [Outcome((STATUS_OK,))])
    assert requests == [ReadStatus()]
    assert result[0] == ChannelStatus(ready=True)


def test_function_failed_reads_kd_at_once_for_its_reason() -> None:
    kd = Outcome((ok(b"origin return is not done", dummy=True),))
    requests, error = drive(SetSpeed(1, 5), [Outcome((make_answer(0x32),), 0x32), kd])
    assert requests == [SetSpeed(1, 5), ReadLastError()]
    assert isinstance(error, FunctionFailedError)
    assert (error.command, error.reason) == ("CB", "origin return is not done")


def test_a_failed_kd_leaves_the_reason_empty() -> None:
    outcomes = [Outcome((make_answer(0x32),), 0x32), failed(FailReason.TIMEOUT)]
    requests, error = drive(ReadStatus(), outcomes)
    assert len(requests) == 2
    assert isinstance(error, FunctionFailedError) and error.reason is None


def test_kd_failing_itself_does_not_ask_kd_again() -> None:
    requests, error = drive(ReadLastError(), [Outcome((make_answer(0x32),), 0x32)])
    assert requests == [ReadLastError()]
    assert isinstance(error, FunctionFailedError)


@pytest.mark.parametrize(("flag", "kind"), [(0x31, RejectedError), (0x33, NotSupportedError)])
def test_other_error_flags_need_no_kd(flag: int, kind: type[Exception]) -> None:
    requests, error = drive(ReadStatus(), [Outcome((make_answer(flag),), flag)])
    assert requests == [ReadStatus()]
    assert type(error) is kind


def test_an_answer_that_does_not_decode_is_malformed() -> None:
    # A read is asked once more (the bad answer may be a stale one), then it is an error.
    bad = Outcome((ok(b"12"),))
    requests, error = drive(ReadPosition(1), [bad, bad], Policy(0.5, 1))
    assert requests == [ReadPosition(1), ReadPosition(1)]
    assert isinstance(error, MalformedAnswerError) and error.command == "AC"
    garbled = Outcome((make_answer(0x30, b"\x84\x84\x00"),))
    requests, error = drive(ReadStatus(), [garbled, garbled], Policy(0.5, 1))
    assert len(requests) == 2
    assert isinstance(error, MalformedAnswerError)
    assert isinstance(error.__cause__, FieldError)


def test_a_read_whose_answer_does_not_decode_is_asked_again() -> None:
    # A stale bare "0" (another command's answer resent late) reaches AA first.
    requests, result = drive(ReadStatus(), [Outcome((ok(),)), Outcome((STATUS_OK,))])
    assert requests == [ReadStatus(), ReadStatus()]
    assert isinstance(result, tuple)
    requests, error = drive(ReadStatus(), [Outcome((ok(),))], Policy(0.5, 0))
    assert len(requests) == 1 and isinstance(error, MalformedAnswerError)


def test_a_state_change_whose_answer_does_not_decode_has_an_unknown_outcome() -> None:
    requests, error = drive(Servo(1, True), [Outcome((ok(b"x"), ok()))])
    assert requests == [Servo(1, True)]
    assert isinstance(error, OutcomeUnknownError) and error.command == "DB"
    assert isinstance(error.__cause__, MalformedAnswerError)


# -- lost answers: reads are retried, state changes never resent --------------------------------
def test_a_read_is_retried_after_a_timeout() -> None:
    outcomes = [failed(FailReason.TIMEOUT), Outcome((STATUS_OK,))]
    requests, result = drive(ReadStatus(), outcomes)
    assert requests == [ReadStatus(), ReadStatus()]
    assert isinstance(result, tuple)


def test_a_read_gives_up_after_its_retries() -> None:
    requests, error = drive(ReadStatus(), [failed(FailReason.TIMEOUT)] * 3)
    assert len(requests) == 3
    assert isinstance(error, ReplyTimeoutError) and isinstance(error, TimeoutError)
    assert error.command == "AA" and error.timeout == 0.5


def test_zero_retries_means_one_try() -> None:
    requests, error = drive(ReadStatus(), [failed(FailReason.TIMEOUT)], Policy(0.5, 0))
    assert len(requests) == 1 and isinstance(error, ReplyTimeoutError)


def test_a_state_change_is_never_resent() -> None:
    requests, error = drive(SetSpeed(1, 5), [failed(FailReason.TIMEOUT)])
    assert requests == [SetSpeed(1, 5)]
    assert isinstance(error, OutcomeUnknownError) and error.command == "CB"


@pytest.mark.parametrize(
    ("failure", "kind"),
    [
        (failed(FailReason.RESET, detail="RST received"), LinkResetError),
        (failed(FailReason.NAK_LIMIT, detail="4 NAKs for one packet"), NakLimitError),
        (failed(FailReason.ABORTED, detail="aborted by the application"), LinkResetError),
    ],
)
def test_line_failures_become_typed_errors(failure: Outcome, kind: type[Exception]) -> None:
    requests, error = drive(ReadStatus(), [failure])
    assert len(requests) == 1
    assert type(error) is kind
    # Once the request was out, an RST or an abort says nothing of whether a state change was
    # carried out; only NAKs for the request itself prove it was not taken.
    requests, error = drive(SetSpeed(1, 5), [failure])
    assert len(requests) == 1
    expected = NakLimitError if kind is NakLimitError else OutcomeUnknownError
    assert type(error) is expected
    assert error.command == "CB"


def test_a_broken_rule_raises_the_links_error() -> None:
    rule = LinkRuleError("host", "WAIT_ANSWER", "packet", "unknown flag")
    outcome = Outcome((), failure=ExchangeFailed(FailReason.RULE, State.WAIT_ANSWER, "x", rule))
    _, error = drive(ReadStatus(), [outcome])
    assert error is rule


def _out_of_step() -> Outcome:
    rule = LinkRuleError("host", "WAIT_MORE", "packet", "the controller runs ahead of our ACKs")
    failure = ExchangeFailed(FailReason.OUT_OF_STEP, State.WAIT_MORE, str(rule), rule)
    return Outcome((ok(b"0003"),), failure=failure)


def test_a_read_given_up_out_of_step_is_asked_again() -> None:
    # A multi-packet answer sent ahead of the host's ACKs (issue 30): the next try starts in
    # step, as after a timeout.
    download = DownloadFile(1, "H5.JOB")
    answer = Outcome((ok(b"0001"), ok(b"MAIN\n"), make_answer(0x34)))
    requests, result = drive(download, [_out_of_step(), answer])
    assert requests == [download, download]
    assert result == JobFile(("MAIN",), announced=1)
    requests, error = drive(download, [_out_of_step()] * 3)
    assert len(requests) == 3 and isinstance(error, LinkRuleError)


def test_a_state_change_whose_answer_kept_arriving_corrupt_has_an_unknown_outcome() -> None:
    corrupt = failed(FailReason.NAK_LIMIT, detail="4th corrupt packet in a row")
    _, error = drive(SetSpeed(1, 5), [corrupt])
    assert isinstance(error, OutcomeUnknownError)
    _, error = drive(ReadStatus(), [corrupt])
    assert isinstance(error, NakLimitError)


reasons = st.sampled_from(list(FailReason))


@given(st.lists(reasons, min_size=1, max_size=6), st.integers(0, 4))
def test_a_state_change_is_sent_once_whatever_fails(
    failures: list[FailReason], retries: int
) -> None:
    outcomes = [failed(reason) for reason in failures] + [Outcome((ok(),))]
    requests, _ = drive(SetSpeed(1, 5), outcomes, Policy(0.5, retries))
    assert requests.count(SetSpeed(1, 5)) == 1


@given(st.lists(reasons, min_size=1, max_size=6), st.integers(0, 4))
def test_a_read_is_sent_at_most_retries_plus_one_times(
    failures: list[FailReason], retries: int
) -> None:
    outcomes = [failed(reason) for reason in failures] + [Outcome((STATUS_OK,))]
    requests, _ = drive(ReadStatus(), outcomes, Policy(0.5, retries))
    assert 1 <= len(requests) <= retries + 1


# -- uploads are verified ----------------------------------------------------------------------
LINES = ("MAIN", "JMOV P1", "EOP")
UPLOAD = UploadFile(1, "NEW.JOB", 3, LINES)
REPLY = make_answer(0x30, dummy=True)


def test_an_upload_ends_with_its_ack() -> None:
    requests, result = drive(UPLOAD, [Outcome((REPLY,) * 4, lines_sent=3)])
    assert requests == [UPLOAD] and result is None


def test_a_refused_upload_request_is_the_controllers_error() -> None:
    refusal = Outcome((make_answer(0x32, dummy=True),), 0x32)
    kd = Outcome((ok(b"job number differs", dummy=True),))
    requests, error = drive(UPLOAD, [refusal, kd])
    assert requests == [UPLOAD, ReadLastError()]
    assert isinstance(error, FunctionFailedError) and error.reason == "job number differs"


def test_a_line_refused_midway_is_an_incomplete_upload() -> None:
    refusal = Outcome((REPLY, REPLY, make_answer(0x31, dummy=True)), 0x31, lines_sent=1)
    _, error = drive(UPLOAD, [refusal])
    assert isinstance(error, UploadIncompleteError)
    assert "line 2 of 3" in str(error)
    assert isinstance(error.__cause__, RejectedError)


def test_an_upload_cut_short_is_incomplete_and_not_resent() -> None:
    cut = Outcome((REPLY,), failure=ExchangeFailed(FailReason.TIMEOUT, State.UPLOAD_WAIT_REPLY))
    requests, error = drive(UPLOAD, [cut])
    assert requests == [UPLOAD]
    assert isinstance(error, UploadIncompleteError)
    assert isinstance(error.__cause__, OutcomeUnknownError)


def lost_final_ack() -> Outcome:
    failure = ExchangeFailed(FailReason.TIMEOUT, State.UPLOAD_WAIT_ACK, "no answer")
    return Outcome((REPLY,) * 4, failure=failure, lines_sent=3)


def download(lines: Sequence[str]) -> Outcome:
    body = [ok(b"%04d" % len(lines), dummy=True)]
    body += [ok(line.encode() + b"\n", dummy=True) for line in lines]
    return Outcome((*body, make_answer(0x34, dummy=True)))


def test_a_lost_final_ack_is_checked_by_reading_the_file_back() -> None:
    requests, result = drive(UPLOAD, [lost_final_ack(), download(LINES)])
    assert requests == [UPLOAD, DownloadFile(1, "NEW.JOB")]
    assert result is None


def test_a_lost_final_ack_and_a_different_file_is_incomplete() -> None:
    _, error = drive(UPLOAD, [lost_final_ack(), download(("MAIN", "EOP"))])
    assert isinstance(error, UploadIncompleteError) and "differs" in str(error)


def test_a_lost_final_ack_and_no_read_back_is_incomplete() -> None:
    timeouts = [failed(FailReason.TIMEOUT)] * 3
    _, error = drive(UPLOAD, [lost_final_ack(), *timeouts])
    assert isinstance(error, UploadIncompleteError)
    assert isinstance(error.__cause__, ReplyTimeoutError)


def test_a_points_upload_is_compared_point_by_point() -> None:
    points = {4: Point((1.0, 2.0), used=True)}
    lines = tuple(format_point_line(n, p) for n, p in points.items())
    upload = UploadFile(1, "P.PNT", 0, lines)
    readback = Outcome(
        (
            ok(b"0004", dummy=True),
            ok(lines[0].encode() + b"\n", dummy=True),
            make_answer(0x34, dummy=True),
        )
    )
    requests, result = drive(upload, [lost_final_ack(), readback])
    assert result is None and requests[1] == DownloadFile(1, "P.PNT")
    moved = Outcome(
        (
            readback.packets[0],
            ok(lines[0].replace("1.000", "1.500").encode() + b"\n", dummy=True),
            readback.packets[2],
        )
    )
    _, error = drive(upload, [lost_final_ack(), moved])
    assert isinstance(error, UploadIncompleteError)


# -- the exchange step object against a controller link ------------------------------------------
class Line:
    """A HostLink-driven Exchange and a ControllerLink, wired back to back on a fake clock."""

    def __init__(self) -> None:
        self.host = HostLink(timeout=1.0)
        self.controller = ControllerLink(timeout=1.0)
        self.now = 0.0
        self.controller_events: list[Any] = []

    def pump(self, exchange: Exchange) -> None:
        for _ in range(200):
            out = exchange.output()
            if out:
                self.controller_events += self.controller.receive_data(out, self.now)
            back = self.controller.data_to_send()
            if back:
                exchange.receive(back, self.now)
            if exchange.done or not (out or back):
                return

    def answer(self, packets: list[bytes], after: After) -> None:
        self.controller_events += self.controller.send_answer(packets, after, self.now)


def test_exchange_collects_a_multi_packet_answer_with_progress() -> None:
    line = Line()
    seen: list[tuple[int, int | None]] = []
    exchange = Exchange(line.host, DownloadFile(1, "A.JOB"), lambda d, t: seen.append((d, t)))
    exchange.start(line.now)
    line.pump(exchange)
    assert isinstance(line.controller_events[-1], RequestReceived)
    answer = DownloadFile(1, "A.JOB").encode_answer(JobFile(("MAIN", "EOP")))
    line.answer(answer, After.DONE)
    line.pump(exchange)
    assert exchange.done
    outcome = exchange.outcome()
    assert outcome.failure is None and outcome.flag is None and len(outcome.packets) == 4
    assert seen == [(1, 4), (2, 4), (3, 4), (4, 4)]


def test_exchange_feeds_upload_lines_as_the_controller_asks() -> None:
    line = Line()
    seen: list[tuple[int, int | None]] = []
    exchange = Exchange(line.host, UPLOAD, lambda d, t: seen.append((d, t)))
    exchange.start(line.now)
    line.pump(exchange)
    stored: list[bytes] = []
    line.answer([REPLY], After.UPLOAD)
    for _ in range(len(LINES) + 1):
        line.pump(exchange)
        event = line.controller_events[-1]
        assert isinstance(event, UploadPacketReceived)
        if event.end:
            line.controller_events += line.controller.accept_upload(line.now)
        else:
            stored.append(event.data)
            line.answer([REPLY], After.UPLOAD)
    line.pump(exchange)
    assert exchange.done and exchange.outcome().failure is None
    assert stored == [b"MAIN\n", b"JMOV P1\n", b"EOP\n"]
    assert exchange.outcome().lines_sent == 3
    assert seen == [(1, 3), (2, 3), (3, 3)]


def test_an_answer_taken_where_it_lands_is_the_answer_receive_would_take() -> None:
    """answer_at_once (an asyncio transport's callback) takes exactly a single exchange's clean
    answer, returns its ACK and ends the exchange as receive() would; anything else it declines,
    changing nothing, and receive() then decides."""
    answer = encode_packet(STATUS_OK)
    taken, plain = HostLink(timeout=1.0), HostLink(timeout=1.0)
    at_once, received = Exchange(taken, ReadStatus()), Exchange(plain, ReadStatus())
    for exchange in (at_once, received):
        exchange.start(0.0)
        exchange.output()
    assert at_once.answer_at_once(answer, 0.1) == bytes((ACK,))
    received.receive(answer, 0.1)
    assert received.output() == bytes((ACK,))
    assert at_once.done and received.done
    assert at_once.outcome() == received.outcome()
    assert at_once.outcome().packets == (STATUS_OK,)
    assert taken.state is plain.state and taken.idle
    # Declined: half a frame, an error flag, a multi-packet exchange.
    for data, command in (
        (answer[:3], ReadStatus()),
        (encode_packet(b"\xff2"), ReadStatus()),
        (answer, DownloadFile(1, "A.JOB")),
    ):
        link = HostLink(timeout=1.0)
        exchange = Exchange(link, command)
        exchange.start(0.0)
        assert exchange.output()
        state = link.state
        assert exchange.answer_at_once(data, 0.1) is None
        assert not exchange.done and link.data_to_send() == b"" and link.state is state
        exchange.receive(data, 0.1)  # the rules still take it from here


def test_exchange_refuses_a_bad_field_before_anything_is_sent() -> None:
    line = Line()
    with pytest.raises(FieldError):
        Exchange(line.host, SetSpeed(1, 5000))
    assert line.host.idle and line.host.data_to_send() == b""


def test_exchange_times_out_on_its_deadline_and_resets_the_line() -> None:
    line = Line()
    exchange = Exchange(line.host, ReadStatus())
    exchange.start(0.0)
    assert exchange.output().startswith(b"\x02\xffAA")
    assert exchange.deadline() == 1.0
    exchange.tick(0.5)
    assert not exchange.done
    exchange.tick(1.0)
    assert exchange.done and exchange.outcome().failure is not None
    assert exchange.output() == b"\x12"  # RST, so that the controller drops the exchange too


def test_exchange_abort_sends_rst() -> None:
    line = Line()
    exchange = Exchange(line.host, ReadStatus())
    exchange.start(0.0)
    exchange.output()
    exchange.abort(0.1)
    assert exchange.done and exchange.output() == b"\x12" and not line.host.busy


def _answer_reads() -> list[bytes]:
    """Reads an exchange may see: answers of every flag, damaged ones, more than a frame."""
    from robostar.protocol.frame import encode_packet

    good = encode_packet(STATUS_OK)
    return [
        good,
        encode_packet(b"\xff" + STATUS_OK),
        encode_packet(ok()),  # too short for AA: decodes as malformed
        encode_packet(ok(b"12")),
        encode_packet(make_answer(0x31)),
        encode_packet(make_answer(0x32)),
        encode_packet(make_answer(0x34)),
        encode_packet(b"9"),
        good[:-1] + bytes((good[-1] ^ 1,)),
        b"\x06" + good,
        good + b"\x06",
        good + good,
        good[:3],
        b"x" + good,
    ]


@pytest.mark.parametrize("read", _answer_reads(), ids=lambda r: r.hex(" "))
@pytest.mark.parametrize("with_progress", [False, True])
def test_a_single_exchange_takes_a_clean_answer_as_the_general_path_does(
    read: bytes, with_progress: bool
) -> None:
    """The one-step read of a clean answer (HostLink.receive_clean_answer) gives the same
    outcome, bytes and progress calls as handing every read to HostLink.receive_data."""
    runs = []
    for one_step in (True, False):
        seen: list[tuple[int, int | None]] = []

        def progress(done: int, total: int | None, seen: list[Any] = seen) -> None:
            seen.append((done, total))

        host = HostLink(timeout=1.0)
        exchange = Exchange(host, ReadStatus(), progress if with_progress else None)
        exchange._single = one_step
        exchange.start(0.0)
        sent = [exchange.output()]
        exchange.receive(read, 0.1)
        sent.append(exchange.output())
        if not exchange.done:
            exchange.tick(5.0)
            sent.append(exchange.output())
        assert exchange.done
        outcome = exchange.outcome()
        failure = outcome.failure
        error = failure and failure.error
        runs.append(
            (
                (outcome.packets, outcome.flag, outcome.lines_sent),
                failure and (failure.reason, failure.state, failure.detail),
                error and (type(error), str(error)),
                sent,
                seen,
                host.state,
                host.next_deadline(),
            )
        )
    assert runs[0] == runs[1]
