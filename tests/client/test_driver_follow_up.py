"""The rules after a command's first exchange, as both clients share them (driver.follow_up).

``follow_up`` is driven with made-up exchange outcomes, by hand and by the two plan loops the
clients drive it with (``run_plan`` and ``run_plan_async``): which exchange comes next, whether
it is a retry (only a retry keeps the caller's progress), and the result or typed error.
"""

from __future__ import annotations

import asyncio
from collections.abc import Sequence
from typing import Any, cast

import pytest

from robostar.client.driver import FollowUp, Policy, follow_up
from robostar.client.exchange import Exchange, Outcome
from robostar.client.plan import run_plan, run_plan_async
from robostar.commands.base import Command, make_answer
from robostar.commands.control import SetSpeed
from robostar.commands.status import ReadStatus
from robostar.commands.system import ReadLastError
from robostar.errors import FunctionFailedError, OutcomeUnknownError, ReplyTimeoutError
from robostar.protocol.link import ExchangeFailed, FailReason, State
from robostar.types import ChannelStatus

POLICY = Policy(timeout=0.5, retries=1)
STATUS_OK = make_answer(0x30, bytes((0x84, 0x84, 0x80)))
TIMED_OUT = Outcome((), failure=ExchangeFailed(FailReason.TIMEOUT, State.WAIT_ANSWER, ""))
FAILED_32 = Outcome((make_answer(0x32),), 0x32)
KD_REASON = Outcome((make_answer(0x30, b"origin return is not done", dummy=True),))


class Ended:
    """An exchange that is over: all ``follow_up`` reads of one is its outcome."""

    def __init__(self, outcome: Outcome) -> None:
        self._outcome = outcome

    def outcome(self) -> Outcome:
        return self._outcome


def ended(outcome: Outcome) -> Exchange:
    return cast(Exchange, Ended(outcome))


def progress(done: int, total: int | None) -> None:
    """A caller's progress callback (never called here: only passed along)."""


def drive(
    command: Command[Any], first: Outcome, later: Sequence[Outcome]
) -> tuple[list[FollowUp], Any]:
    """Drive follow_up by hand; (the follow-ups asked for, result|error)."""
    steps: list[FollowUp] = []
    replies = iter(later)
    plan = follow_up(command, ended(first), POLICY, progress)
    try:
        step = next(plan)
        while True:
            steps.append(step)
            step = plan.send(ended(next(replies)))
    except StopIteration as stop:
        return steps, stop.value
    except Exception as exc:
        return steps, exc


def test_a_lost_answer_to_a_read_is_retried_with_the_progress() -> None:
    command = ReadStatus()
    steps, result = drive(command, TIMED_OUT, [Outcome((STATUS_OK,))])
    assert steps == [FollowUp(command, True, progress)]
    assert steps[0].command is command
    assert result[0] == ChannelStatus(ready=True)


def test_a_failed_function_reads_kd_as_a_new_exchange_without_progress() -> None:
    steps, error = drive(SetSpeed(1, 5), FAILED_32, [KD_REASON])
    assert steps == [FollowUp(ReadLastError(), False, None)]
    assert isinstance(error, FunctionFailedError)
    assert error.reason == "origin return is not done"


def test_a_lost_answer_to_a_state_change_asks_for_nothing_more() -> None:
    steps, error = drive(SetSpeed(1, 5), TIMED_OUT, [])
    assert steps == []
    assert isinstance(error, OutcomeUnknownError)


def test_retries_end_at_the_policy() -> None:
    steps, error = drive(ReadStatus(), TIMED_OUT, [TIMED_OUT])
    assert [step.retry for step in steps] == [True]
    assert isinstance(error, ReplyTimeoutError)


def _sync_run(command: Command[Any], first: Outcome, later: Sequence[Outcome]) -> Any:
    replies = iter(later)
    return run_plan(
        follow_up(command, ended(first), POLICY, None), lambda step: ended(next(replies))
    )


def _async_run(command: Command[Any], first: Outcome, later: Sequence[Outcome]) -> Any:
    replies = iter(later)

    async def exchange(step: FollowUp) -> Exchange:
        await asyncio.sleep(0)
        return ended(next(replies))

    return asyncio.run(run_plan_async(follow_up(command, ended(first), POLICY, None), exchange))


@pytest.mark.parametrize("run", [_sync_run, _async_run], ids=["sync", "asyncio"])
def test_both_flavours_drive_the_same_rules(run: Any) -> None:
    assert run(ReadStatus(), TIMED_OUT, [Outcome((STATUS_OK,))])[0] == ChannelStatus(ready=True)
    with pytest.raises(FunctionFailedError) as failed:
        run(SetSpeed(1, 5), FAILED_32, [KD_REASON])
    assert failed.value.reason == "origin return is not done"


class Boom(Exception):
    pass


def test_an_error_of_the_follow_up_exchange_reaches_the_caller_unchanged() -> None:
    # The exchange's own error (a lost port, Ctrl-C, a cancelled task) is not the rules' to
    # turn into anything else.
    def boom(step: FollowUp) -> Exchange:
        raise Boom

    async def aboom(step: FollowUp) -> Exchange:
        raise Boom

    with pytest.raises(Boom):
        run_plan(follow_up(ReadStatus(), ended(TIMED_OUT), POLICY, None), boom)
    with pytest.raises(Boom):
        asyncio.run(run_plan_async(follow_up(ReadStatus(), ended(TIMED_OUT), POLICY, None), aboom))
