"""Every error reads as a sentence with what to do next, and maps to its exit code."""

from __future__ import annotations

import pytest

from robostar.cli.failures import EXIT_BAD_ARGUMENT, EXIT_LINE, EXIT_REFUSED, explain
from robostar.errors import (
    AlarmRaisedError,
    FieldError,
    FunctionFailedError,
    JogInterruptedError,
    LinkResetError,
    MalformedAnswerError,
    NakLimitError,
    NotSupportedError,
    OutcomeUnknownError,
    PortError,
    RejectedError,
    ReplyTimeoutError,
    RobostarError,
    UploadIncompleteError,
    UsageError,
    WaitTimeoutError,
)
from robostar.types import Alarm, ChannelStatus


def jog_lost() -> JogInterruptedError:
    error = JogInterruptedError("the keepalive failed")
    error.__cause__ = ReplyTimeoutError("BF", 2.0)
    return error


CASES: list[tuple[RobostarError, int, str]] = [
    (UsageError("axis: 7 is not 1-6"), EXIT_BAD_ARGUMENT, "Axis: 7 is not 1-6."),
    (FieldError("CB", "speed", "2000 is out of range 0..1000"), EXIT_BAD_ARGUMENT, "speed"),
    (
        FunctionFailedError("BC", "servo off"),
        EXIT_REFUSED,
        "move was refused by the controller: servo off.",
    ),
    (FunctionFailedError("BC"), EXIT_REFUSED, "it gave no reason"),
    (RejectedError("GA", "port must be 2 digits"), EXIT_REFUSED, "port must be 2 digits"),
    (NotSupportedError("CX"), EXIT_REFUSED, "does not support setting the reference axis"),
    (ReplyTimeoutError("AA", 2.0), EXIT_LINE, "No answer from the controller at PORT"),
    (OutcomeUnknownError("BC"), EXIT_LINE, "outcome is unknown"),
    (NakLimitError("AA", 3), EXIT_LINE, "NAK"),
    (LinkResetError("AA"), EXIT_LINE, "aborted"),
    (UploadIncompleteError("FB: no final ACK"), EXIT_LINE, "FB"),
    (PortError("/dev/ttyUSB0: permission denied"), EXIT_LINE, "/dev/ttyUSB0"),
    (MalformedAnswerError("AC", "short"), EXIT_LINE, "broke the protocol"),
    (
        AlarmRaisedError("alarm while moving", 1, ChannelStatus(alarm=True), (Alarm(9003, "X"),)),
        EXIT_REFUSED,
        "Alarm while moving.",
    ),
    (WaitTimeoutError("did not stop", 1, None), EXIT_REFUSED, "Did not stop."),
    (jog_lost(), EXIT_LINE, "The jog stopped: no answer"),
]


@pytest.mark.parametrize(("error", "code", "text"), CASES, ids=lambda c: type(c).__name__)
def test_exit_code_sentence_and_hint(error: RobostarError, code: int, text: str) -> None:
    failure = explain(error, "PORT")
    assert failure.exit_code == code
    assert text in failure.message
    assert failure.message.endswith(".")
    assert failure.hint
    assert failure.as_json()["error"]["exit_code"] == code


def test_refusal_keeps_the_reason_for_json() -> None:
    failure = explain(FunctionFailedError("DC", "no such file"), "sim://")
    assert failure.as_json()["error"]["reason"] == "no such file"
    assert failure.as_json()["error"]["command"] == "DC"
