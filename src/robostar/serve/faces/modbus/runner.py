"""The handshake's runner: a new sequence number's command goes to the line (through the lease,
as the PLC's named holder, and the audit log), and its outcome to the result registers.

One command of the PLC runs at a time; a new one that comes while another runs is refused as
busy (reason 6) rather than queued, so that the PLC always knows which of its commands ran.
Stops are the exception: they run at once, beside anything running, ahead of the line's queue,
and what the PLC asked before them and is not on the wire yet never goes out (the CC of a
run_job still selecting its JOB, a request waiting in the line's queue): it is refused as
aborted (reason 9).
The result registers only ever show the newest sequence number's outcome: a command that ends
after a newer one was taken (a stop, a busy refusal) leaves them alone.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from robostar.commands.base import Command
from robostar.commands.control import StartJob
from robostar.commands.files import ListFiles
from robostar.commands.job import SelectJob
from robostar.errors import (
    ControllerError,
    LineError,
    OutcomeUnknownError,
    RobostarError,
    UsageError,
)
from robostar.serve.audit import AuditError
from robostar.serve.faces.modbus.handshake import (
    CODES,
    Request,
    Sequencer,
    Take,
    parse_request,
)
from robostar.serve.faces.modbus.image import text_words
from robostar.serve.faces.modbus.layout import HR, TEXT_REGISTERS, Outcome, Reason
from robostar.serve.lease import LeaseHeldError, Who
from robostar.serve.line import AbortedByStopError, LineDownError, WithdrawnError

if TYPE_CHECKING:
    from robostar.serve.line import Line

__all__ = ["CommandRunner", "JobTable"]

log = logging.getLogger("robostar.serve.modbus")


class JobTable:
    """JOB numbers by file name per channel, from FD's listing (read when a number or a name is
    not known yet: a file list changes rarely, and only through a file transfer)."""

    def __init__(self, line: Line) -> None:
        self.line = line
        self.numbers: dict[int, dict[str, int]] = {}
        self.reads = 0
        """JOB lists read so far (the map is rebuilt after each)."""

    async def refresh(self, channel: int) -> dict[str, int]:
        records = await self.line.read(ListFiles(channel), max_age=0)
        numbers = {r.name.upper(): r.job_number for r in records if r.name.upper().endswith(".JOB")}
        self.numbers[channel] = numbers
        self.reads += 1
        return numbers

    async def file_of(self, channel: int, number: int) -> str | None:
        """The JOB file of ``number`` on ``channel`` (read afresh), None when there is none."""
        numbers = await self.refresh(channel)
        return next((name for name, n in numbers.items() if n == number), None)


class CommandRunner:
    """The command block of one line (see the module docstring)."""

    def __init__(self, line: Line, who: Who, allowed: frozenset[str], jobs: JobTable) -> None:
        self.line = line
        self.who = who
        self.allowed = allowed
        self.jobs = jobs
        self.sequencer = Sequencer()
        self.registers = [0] * (HR.SIZE - HR.WRITABLE)
        """HR.WRITABLE .. HR.SIZE: done sequence, outcome, flag, reason, accepted, text."""
        self._running: asyncio.Task[None] | None = None
        self._running_sequence = 0
        self._stops = 0
        """Stops taken so far: a command whose steps see it change sends no more of them."""
        self.tasks: set[asyncio.Task[None]] = set()

    def _set(self, address: int, value: int) -> None:
        self.registers[address - HR.WRITABLE] = value

    def submit(self, block: Sequence[int]) -> None:
        """The command block after a PLC's write: run its command if its sequence is new."""
        sequence = block[HR.SEQUENCE]
        take = self.sequencer.take(sequence)
        if take is Take.NOTHING:
            return
        self._set(HR.ACCEPTED_SEQUENCE, sequence)
        name = CODES.get(block[HR.COMMAND], (f"code {block[HR.COMMAND]}", None))[0]
        if take is Take.BASELINE:
            text = "the first sequence number since the face started: write a new one"
            self._refuse(sequence, f"modbus {name}", Reason.RESTARTED, text)
            return
        try:
            request = parse_request(block)
        except RobostarError as exc:
            reason = (
                Reason.UNKNOWN_COMMAND if block[HR.COMMAND] not in CODES else Reason.BAD_PARAMETER
            )
            self._refuse(sequence, f"modbus {name}", reason, str(exc))
            return
        if request.name not in self.allowed:
            allowed = ", ".join(sorted(self.allowed))
            text = f"{request.name} is not allowed on this server (allowed: {allowed})"
            self._refuse(sequence, _what(request), Reason.NOT_ALLOWED, text)
            return
        if not request.is_stop and self._running is not None and not self._running.done():
            text = f"busy: sequence {self._running_sequence} is still running"
            self._refuse(sequence, _what(request), Reason.BUSY, text)
            return
        if request.is_stop:
            # what the PLC asked before the stop and is not on the wire yet must not go out
            # after it: the steps left of a running command, its request waiting in the queue
            self._stops += 1
            self.line.withdraw(self.who, f"modbus sequence {sequence} is a stop")
        task = asyncio.get_running_loop().create_task(
            self._run(request, self._stops),
            name=f"modbus {self.line.name} {request.name} #{sequence}",
        )
        self.tasks.add(task)
        task.add_done_callback(self.tasks.discard)
        if not request.is_stop:
            self._running, self._running_sequence = task, sequence

    def _refuse(self, sequence: int, what: str, reason: Reason, text: str) -> None:
        self.line.record(what, self.who, f"refused: {text}")
        self._finish(sequence, Outcome.REFUSED, reason=reason, text=text)

    def _finish(
        self,
        sequence: int,
        outcome: Outcome,
        *,
        flag: int = 0,
        reason: Reason = Reason.NONE,
        text: str = "",
    ) -> None:
        if sequence != self.sequencer.last:
            # a newer number was taken meanwhile (a stop while a job was being selected, a
            # command refused as busy): its outcome stays, the PLC waits for that one; this
            # one's is in the audit log
            log.info(
                "modbus %s: sequence %d finished (%s) after %s was taken: not published",
                self.line.name,
                sequence,
                outcome.name.lower(),
                self.sequencer.last,
            )
            return
        self._set(HR.OUTCOME, int(outcome))
        self._set(HR.FLAG, flag)
        self._set(HR.REASON, int(reason))
        self.registers[HR.TEXT - HR.WRITABLE :] = text_words(text, TEXT_REGISTERS)
        self._set(HR.DONE_SEQUENCE, sequence)  # last: a PLC that sees it sees the rest too

    async def _run(self, request: Request, stops: int) -> None:
        """Run ``request``, taken when ``stops`` stops had been: any later stop ends it before
        its next command goes out."""
        try:
            for command in await self._commands(request):
                if self._stops != stops:
                    raise _Refusal(
                        Reason.ABORTED, f"a stop came before {command.CODE} was sent: not sent"
                    )
                await self.line.execute(command, who=self.who, implicit_lease=True)
        except _Refusal as refusal:
            self._refuse(request.sequence, _what(request), refusal.reason, str(refusal))
        except ControllerError as exc:
            self._finish(
                request.sequence,
                Outcome.REFUSED_BY_CONTROLLER,
                flag=exc.flag,
                text=exc.reason or str(exc),
            )
        except OutcomeUnknownError as exc:
            self._finish(request.sequence, Outcome.OUTCOME_UNKNOWN, text=str(exc))
        except RobostarError as exc:  # audited by Line.execute
            self._finish(request.sequence, Outcome.REFUSED, reason=_reason(exc), text=str(exc))
        except asyncio.CancelledError:
            self._finish(request.sequence, Outcome.OUTCOME_UNKNOWN, text="the server stopped")
            raise
        except Exception as exc:  # a bug must not leave the PLC waiting for ever
            log.exception("modbus %s: %s failed", self.line.name, request.name)
            self._finish(request.sequence, Outcome.REFUSED, reason=Reason.FAILED, text=repr(exc))
        else:
            self._finish(request.sequence, Outcome.DONE)

    async def _commands(self, request: Request) -> list[Command[Any]]:
        if request.job is None:
            return list(request.commands)
        try:
            name = await self.jobs.file_of(request.channel, request.job)
        except RobostarError as exc:
            raise _Refusal(_reason(exc), f"the JOB list could not be read: {exc}") from exc
        if name is None:
            raise _Refusal(
                Reason.NO_SUCH_JOB, f"no JOB number {request.job} on channel {request.channel}"
            )
        commands: list[Command[Any]] = [SelectJob(request.channel, name)]
        if request.start:
            commands.append(StartJob(request.channel))
        return commands

    async def stop(self) -> None:
        for task in list(self.tasks):
            task.cancel()
        if self.tasks:
            await asyncio.gather(*self.tasks, return_exceptions=True)


class _Refusal(RobostarError):
    def __init__(self, reason: Reason, text: str) -> None:
        super().__init__(text)
        self.reason = reason


def _what(request: Request) -> str:
    if request.commands:
        return repr(request.commands[0]) if len(request.commands) == 1 else request.name
    return f"modbus {request.name} channel {request.channel} JOB number {request.job}"


def _reason(exc: BaseException) -> Reason:
    table: list[tuple[type[BaseException], Reason]] = [
        (LeaseHeldError, Reason.LEASE_HELD),
        (AuditError, Reason.AUDIT_UNAVAILABLE),
        (LineDownError, Reason.LINE_DOWN),
        (AbortedByStopError, Reason.ABORTED),
        (WithdrawnError, Reason.ABORTED),
        (UsageError, Reason.BAD_PARAMETER),
        (LineError, Reason.LINE_DOWN),
    ]
    return next((reason for kind, reason in table if isinstance(exc, kind)), Reason.FAILED)
