"""The rules for running one command, as a plan of exchanges shared by both clients.

:func:`command_plan` yields each command to exchange and receives its :class:`Outcome`:

- an error flag raises its :class:`~robostar.errors.ControllerError`; on 0x32 the controller's
  reason is read with KD at once (the next exchange) and put in ``reason``;
- a lost answer is retried for read-only commands (``retries`` times) and becomes
  :class:`~robostar.errors.OutcomeUnknownError` for state-changing ones, which are never resent;
- RST, NAK exhaustion and broken link rules become their typed errors;
- an FB upload is verified or raises :class:`~robostar.errors.UploadIncompleteError`; when only
  its final ACK is lost, the file is read back with FA and compared before success is declared.
"""

from __future__ import annotations

import enum
import logging
from collections.abc import Generator
from dataclasses import dataclass
from typing import Any, TypeVar, cast

from robostar.client.exchange import Exchange, Outcome, Progress
from robostar.commands.base import Command
from robostar.commands.files import DownloadFile, UploadFile, parse_point_line
from robostar.commands.status import ReadInfo, ReadStatus
from robostar.commands.system import ReadLastError
from robostar.errors import (
    AnswerTooLongError,
    ControllerError,
    FieldError,
    LinkResetError,
    LinkRuleError,
    MalformedAnswerError,
    NakLimitError,
    OutcomeUnknownError,
    ReplyTimeoutError,
    RobostarError,
    UploadIncompleteError,
    error_for_flag,
)
from robostar.protocol.fields import FLAG_FAILED
from robostar.protocol.link import MAX_NAKS, ExchangeFailed, FailReason, Fence, State
from robostar.types import CoordSystem, JobFile, PointFile

__all__ = [
    "FENCES",
    "NOT_DECODED",
    "CommandPlan",
    "FollowUp",
    "FollowUpPlan",
    "Policy",
    "command_plan",
    "decode",
    "decoded_at_once",
    "follow_up",
    "note_cancelled",
    "upload_matches",
]

log = logging.getLogger("robostar")

T = TypeVar("T")
CommandPlan = Generator[Command[Any], Outcome, T]
"""Yields a command to exchange, receives how the exchange ended, returns the result."""


@dataclass(frozen=True, slots=True)
class Policy:
    """``timeout``: the reply timeout (s); ``retries``: resends of a read-only command."""

    timeout: float = 2.0
    retries: int = 1


def decode(command: Command[T], packets: tuple[bytes, ...]) -> T:
    """The command's result; a field that does not decode is a MalformedAnswerError."""
    try:
        return command.decode_answer(packets)
    except MalformedAnswerError:
        raise
    except FieldError as exc:
        raw = packets[0] if len(packets) == 1 else b""
        raise MalformedAnswerError(command.CODE, str(exc), raw) from exc


def _flag_error(code: str, flag: int) -> CommandPlan[ControllerError]:
    """The error for a flag; for 0x32, with KD's reason read in the very next exchange."""
    reason = None
    if flag == FLAG_FAILED and code != ReadLastError.CODE:
        kd = ReadLastError()
        outcome = yield kd
        if outcome.failure is None and outcome.flag is None:
            try:
                reason = decode(kd, outcome.packets) or None
            except MalformedAnswerError:
                reason = None
    return error_for_flag(flag, code, reason)


def _is_status_answer(data: bytes) -> bool:
    """AA's answer: flag 0x30 and three status bytes (bit7 set, bit6 clear). No other answer
    holds a byte of 0x80-0xBF: every other field is ASCII."""
    return len(data) == 4 and data[0] == 0x30 and all(b & 0xC0 == 0x80 for b in data[1:])


_INFO = ReadInfo()


def _is_info_answer(data: bytes) -> bool:
    """AD's answer: ``FF 0x30`` and the controller's fixed-width description."""
    try:
        _INFO.decode_answer([data])
    except RobostarError:
        return False
    return True


FENCES = (
    Fence(ReadStatus().encode(), _is_status_answer),
    Fence(_INFO.encode(), _is_info_answer),
)
"""The reads that fence off an abandoned exchange (HostLink): AA, whose answer no other can
pass for; AD when an AA was given up (then a late AA answer could pass for the fence's)."""

_OUT_OF_STEP = FailReason.OUT_OF_STEP

_NOT_SENT = (State.RESYNC, State.WAIT_FENCE)
"""States a failure can end in before the request went out (its fence failed, or it waited
for the quiet gap): nothing of the command reached the controller."""


def _answer_was_corrupt(failure: ExchangeFailed) -> bool:
    """NAK exhaustion on our side: the answer arrived, damaged, so the controller acted."""
    return "corrupt" in failure.detail


def failure_error(command: Command[Any], failure: ExchangeFailed, policy: Policy) -> RobostarError:
    """The typed error for an exchange the link gave up on."""
    code = command.CODE
    reason = failure.reason
    if reason is FailReason.TIMEOUT:
        if command.CHANGES_STATE and failure.state not in _NOT_SENT:
            return OutcomeUnknownError(
                code, failure.detail or f"no answer within {policy.timeout:g} s"
            )
        return ReplyTimeoutError(code, policy.timeout, failure.detail)
    if reason is FailReason.NAK_LIMIT:
        if (
            command.CHANGES_STATE
            and _answer_was_corrupt(failure)
            and failure.state not in _NOT_SENT
        ):
            return OutcomeUnknownError(code, "its answer arrived corrupt too many times")
        return NakLimitError(code, MAX_NAKS + 1)
    if reason is FailReason.TOO_LONG or reason is FailReason.RULE or reason is _OUT_OF_STEP:
        error: RobostarError = (
            AnswerTooLongError(code, failure.detail)
            if reason is FailReason.TOO_LONG
            else failure.error
            or LinkRuleError("host", failure.state.value, "packet", failure.detail)
        )
        if command.CHANGES_STATE and failure.state not in _NOT_SENT:
            # The controller answered, so it had the request: whatever broke in its answer,
            # whether it carried the request out is not known (never a plain protocol error).
            unknown = OutcomeUnknownError(code, f"its answer broke the protocol ({error})")
            unknown.__cause__ = error
            return unknown
        return error
    if command.CHANGES_STATE and failure.state not in _NOT_SENT:
        # The request was out: an RST (or a superseded exchange) says nothing of whether the
        # controller carried it out.
        return OutcomeUnknownError(code, failure.detail or reason.value)
    return LinkResetError(code, failure.detail or reason.value)


def note_cancelled(
    exc: BaseException, command: Command[Any], sent: bool, *, answered: bool = False
) -> None:
    """A state change cancelled mid-exchange (an asyncio task): put on the error itself, as a
    PEP 678 note, whether the controller may have carried it out, and log that at WARNING on
    the ``robostar`` logger. The cancellation is not swallowed nor replaced: asyncio's rules
    hold, and only the note is added. ``sent``: the request may have reached the wire;
    ``answered``: the controller's OK answer had come back and been ACKed. A command that
    changes nothing needs no note."""
    if not command.CHANGES_STATE:
        return
    what = f"{command.CODE} ({type(command).__name__})"
    if answered:
        note = (
            f"robostar: {what} was cancelled after the controller had answered it: carried out"
            " (only its result is lost with the cancellation)"
        )
    elif sent:
        note = (
            f"robostar: {what} was cancelled after its request was sent: the outcome is "
            "unknown - the controller may or may not have carried it out; check its state "
            "before sending it again"
        )
    else:
        note = f"robostar: {what} was cancelled before its request was sent: not carried out"
    exc.add_note(note)
    log.warning("%s", note)


class _NotDecoded(enum.Enum):
    NOT_DECODED = 0


NOT_DECODED = _NotDecoded.NOT_DECODED
"""What :func:`decoded_at_once` gives when the rules must look at the outcome."""


def decoded_at_once(command: Command[T], exchange: Exchange) -> T | _NotDecoded:
    """The usual case, without the rules: the result of the first exchange of ``command``
    when it ended with an answer :func:`command_plan` would only decode (no failure, no error
    flag, not an upload: :meth:`Exchange.answer`) and that decodes. Otherwise NOT_DECODED,
    and the clients hand the exchange's outcome to the plan, which applies its rules."""
    packets = exchange.answer()
    if packets is not None:
        try:
            return command.decode_answer(packets)
        except (MalformedAnswerError, FieldError):  # decode()'s errors, before it wraps them
            pass
    return NOT_DECODED


@dataclass(frozen=True, slots=True)
class FollowUp:
    """One more exchange the rules ask for: ``command`` (``retry``: the same command again,
    to be resent as a retry - :meth:`~robostar.protocol.link.HostLink.retry_next`)."""

    command: Command[Any]
    retry: bool
    progress: Progress | None


FollowUpPlan = Generator[FollowUp, Exchange, T]
"""Yields the next exchange to run, receives it once run, returns the command's result."""


def follow_up(
    command: Command[T], first: Exchange, policy: Policy, progress: Progress | None
) -> FollowUpPlan[T]:
    """The rules after ``command``'s first exchange, when :func:`decoded_at_once` could not
    give the result: the part both clients share, driven by each one's own I/O loop
    (``run_plan`` / ``run_plan_async`` with an exchange as the effect). Only a retry of the
    command keeps ``progress``; KD and FA follow-ups report none. The usual case never comes
    here: the clients decode it inline, which keeps the hot path without a generator."""
    plan = command_plan(command, policy)
    next(plan)  # the rules always ask for the command first: ``first`` is its exchange
    outcome = first.outcome()
    while True:
        try:
            request = plan.send(outcome)
        except StopIteration as done:
            return cast(T, done.value)
        again = request is command  # a retry: the rules ask for the same call again
        exchange = yield FollowUp(request, again, progress if again else None)
        outcome = exchange.outcome()


def command_plan(command: Command[T], policy: Policy) -> CommandPlan[T]:
    """Run ``command`` by the rules above; returns its decoded result."""
    if isinstance(command, UploadFile):
        yield from _upload_plan(command, policy)
        return cast(T, None)  # FB's result type is None
    attempt = 0
    while True:
        outcome = yield command
        failure = outcome.failure
        if failure is None:
            if outcome.flag is not None:
                raise (yield from _flag_error(command.CODE, outcome.flag))
            try:
                return decode(command, outcome.packets)
            except MalformedAnswerError as exc:
                # An answer that does not fit the request is most likely a stale one: the
                # controller resending an earlier answer whose ACK reached it late (or an FA
                # download that lost a packet). A read is asked again; for a state-changing
                # command nobody can tell whether it was carried out.
                if command.CHANGES_STATE:
                    raise OutcomeUnknownError(
                        command.CODE, f"its answer did not decode: {exc}"
                    ) from exc
                if attempt < policy.retries:
                    attempt += 1
                    continue
                raise
        # A read is asked again after a timeout, and after an answer given up because the
        # controller ran ahead of our ACKs (a doubled ACK byte): the next try starts in step.
        retry = (
            failure.reason is FailReason.TIMEOUT or failure.reason is _OUT_OF_STEP
        ) and not command.CHANGES_STATE
        if retry and attempt < policy.retries:
            attempt += 1
            continue
        raise failure_error(command, failure, policy)


def upload_matches(command: UploadFile, content: JobFile | PointFile) -> bool:
    """Does the file read back with FA hold exactly what ``command`` uploaded?"""
    if isinstance(content, JobFile):
        return content.lines == command.lines
    uploaded = dict(parse_point_line(line, command="FB") for line in command.lines)
    return content.points == uploaded


def _upload_plan(command: UploadFile, policy: Policy) -> CommandPlan[None]:
    name = f"{command.file} (channel {command.channel})"
    total = len(command.lines)
    outcome = yield command
    failure = outcome.failure
    if failure is None:
        if outcome.flag is None:
            decode(command, outcome.packets)
            return
        error = yield from _flag_error(command.CODE, outcome.flag)
        if len(outcome.packets) == 1:
            raise error  # the request itself was refused: nothing was stored
        done = outcome.lines_sent
        what = f"line {done + 1} of {total}" if done < total else "the closing packet"
        raise UploadIncompleteError(f"FB {name}: the controller refused {what}: {error}") from error
    if failure.reason is FailReason.TIMEOUT and failure.state is State.UPLOAD_WAIT_ACK:
        # Every line was accepted and only the closing ACK is missing: read the file back.
        readback = DownloadFile(command.channel, command.file, CoordSystem.ANGLE)
        try:
            content = yield from command_plan(readback, policy)
        except RobostarError as exc:
            raise UploadIncompleteError(
                f"FB {name}: the final ACK was lost and the file could not be read back: {exc}"
            ) from exc
        if upload_matches(command, content):
            return
        raise UploadIncompleteError(
            f"FB {name}: the final ACK was lost and the file read back differs from the upload"
        )
    cause = failure_error(command, failure, policy)
    raise UploadIncompleteError(
        f"FB {name}: the upload stopped after {outcome.lines_sent} of {total} lines: {cause}"
    ) from cause
