"""Refusals read as words: the reason, the specific next step, codes in the detail line, and
the alarm a refusal left behind."""

from __future__ import annotations

import json

import pytest

from robostar.cli.failures import explain, next_step, with_alarms_left
from robostar.errors import FunctionFailedError
from robostar.types import Alarm

from .conftest import Run


@pytest.mark.parametrize(
    ("reason", "step"),
    [
        ("servo is off on channel 2", "`robostar servo on -c 2`"),
        ("origin return (BA) is not done on channel 1", "`robostar home`"),
        ("no job selected on channel 3; select one with DC", "`robostar job select NAME -c 3`"),
        ("speed is 0 on channel 1; set a speed with CB", "`robostar speed set 100`"),
        ("channel 1 has an alarm; reset it with CG first", "`robostar reset`"),
        ("servo is on (channel 1); CE needs the servo off", "`robostar servo off`"),
    ],
)
def test_next_step_for_known_reasons(reason: str, step: str) -> None:
    assert step in (next_step(reason) or "")


def test_headline_in_words_codes_in_the_detail() -> None:
    failure = explain(FunctionFailedError("DB", "channel 2 has an alarm"), "sim://")
    assert failure.message.startswith("Switching the servo was refused by the controller")
    assert "DB" not in failure.message and "0x32" not in failure.message
    assert "DB" in failure.detail and "0x32" in failure.detail
    assert failure.as_json()["error"]["detail"] == failure.detail


def test_unknown_reason_keeps_a_hint() -> None:
    failure = explain(FunctionFailedError("FE", "the disk is sad"), "sim://")
    assert failure.hint and "last-error" in failure.hint


def test_only_run_fail_alarms_are_reported() -> None:
    failure = explain(FunctionFailedError("CC", "x"), "sim://")
    assert with_alarms_left(failure, [Alarm(1153, "T/P Emergency")]) == failure
    left = with_alarms_left(failure, [Alarm(9002, "Run Fail")])
    assert "9002" in left.hint and "robostar reset" in left.hint
    assert left.alarms == ("9002 : Run Fail",)


def test_refused_select_says_home_and_reports_the_run_fail_alarm(on: Run) -> None:
    human = on("job", "select", "DEMO.JOB")
    assert human.exit_code == 3
    assert "Selecting the job was refused by the controller: origin return" in human.stderr
    assert "Next: the channel is not homed: `robostar home`" in human.stderr
    assert "Run Fail" in human.stderr and "robostar reset" in human.stderr
    assert "Protocol: DC, answer flag 0x32" in human.stderr
    result = on("--json", "job", "select", "DEMO.JOB")
    error = json.loads(result.stderr.splitlines()[-1])["error"]
    assert error["command"] == "DC" and error["alarms_left"] == ["9002 : Run Fail"]
    assert on("reset").exit_code == 0
    after = json.loads(on("--json", "alarms").stdout)
    assert after["alarms"] == []


def test_refusal_without_alarm_says_none(on: Run) -> None:
    result = on("--json", "-c", "2", "job", "start")
    assert result.exit_code == 3
    error = json.loads(result.stderr.splitlines()[-1])["error"]
    assert "job select NAME -c 2" in error["hint"]
    assert error["alarms_left"] == []
