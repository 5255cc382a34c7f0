"""The N1 face's backend: each N1 session's requests handed to one line (queue, lease, model).

Each connection is its own N1 session (robostar.controller_role). Reads are answered from the model
when fresh; state changes go through the line's queue and lease: a connection takes the lease when
it is free and keeps it while active (it expires after the lease's idle time, and is released when
the connection closes). A request refused because another holds the lease answers flag 0x32, and KD
then says, as the line server's refusal, who holds it and until when (robostar's client raises
ControlHeldError from it); a later session's KD tells the controller's text and that refusal
apart. A state change whose outcome the line cannot tell (OutcomeUnknownError: it
may have been carried out) ends its exchange with RST, as a controller does when it cannot answer,
never with a failure flag: a host that retries on failure would send a write that may have run a
second time.

A session's requests still waiting in the line's queue are withdrawn (nothing sent) when its
connection closes or its host gives the exchange up (an RST, a new request): nobody would hear
their outcome, and a write must not reach the robot for a host that has moved on or gone (its
lease is released on disconnect, and another may hold it by then). A given-up exchange ends at
once, whatever the line is doing, so the session takes the host's next request: a host whose
reply timeout is shorter than the line's stays in step with its session.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import TYPE_CHECKING

from robostar.commands.files import UploadFile
from robostar.commands.system import MAX_TEXT, ReadLastError
from robostar.controller_role import Backend, ControllerSession, Refusal, Request
from robostar.errors import (
    ControlHeldError,
    ControllerError,
    OutcomeUnknownError,
    RobostarError,
)
from robostar.serve.lease import LeaseHeldError, Who, utc_clock
from robostar.serve.line import Line

if TYPE_CHECKING:
    pass

__all__ = ["N1Backend"]

log = logging.getLogger("robostar.serve.n1")
_FLAG_FAILED = 0x32
RECENT_REFUSAL = 600.0
"""Seconds a lease refusal is told beside the controller's text by a session's KD."""
_GAVE_UP = "the host gave the exchange up (an RST or a new request)"


class N1Backend(Backend):
    """Hands each session's requests to one :class:`Line`."""

    def __init__(self, line: Line, *, max_age: float | None = None) -> None:
        self.line = line
        self.max_age = max_age
        """None: reads are linearizable; else a model value this many seconds old answers."""
        self._tasks: set[asyncio.Task[None]] = set()
        self.last_refusal: tuple[float, Who, str] | None = None
        """The last lease refusal on this line: when (``time.time()``), to whom, its KD text."""
        self._abandoned: set[Request] = set()
        """Requests whose host gave them up before their task ran (see exchange_abandoned)."""

    @staticmethod
    def who(session: ControllerSession) -> Who:
        return Who(f"n1:{session.name}", "n1")

    def handle(self, request: Request) -> None:
        if isinstance(request.command, ReadLastError) and request.session.last_error:
            request.answer(request.session.last_error)
            return
        task = asyncio.get_running_loop().create_task(self._serve(request))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        task.add_done_callback(lambda _: self._abandoned.discard(request))

    async def _serve(self, request: Request) -> None:
        command = request.command
        who = self.who(request.session)
        if request in self._abandoned:
            # its host gave it up before this task ran (its RST or next request came with it,
            # even in the same read): the withdraw found nothing queued, so nothing may be now
            # (exchange_abandoned already ended its exchange, so the session has moved on)
            if command.CHANGES_STATE:
                self.line.record(command, who, "cancelled, not sent: the host gave it up")
            return
        if not request.live:
            # its connection closed before this task ran: session_closed found nothing of it
            # to withdraw, so it must not be queued now
            return
        try:
            if isinstance(command, ReadLastError):
                result = await self._last_error(request)
            elif command.CHANGES_STATE:
                # "hold": a host program writes in sequences, and keeps control between them
                result = await self.line.execute(command, who=who, lease="hold")
            else:
                result = await self.line.read(command, who=who, max_age=self.max_age)
        except ControllerError as exc:
            self._refuse(request, exc.reason or str(exc), exc.flag or _FLAG_FAILED)
            return
        except LeaseHeldError as exc:
            self._refuse_held(request, who, exc)
            return
        except OutcomeUnknownError as exc:
            # not 0x32: "failed" would tell the host that nothing happened. A controller that
            # cannot say ends the exchange (RST); the host's link then reports the outcome as
            # unknown (robostar's client: OutcomeUnknownError), and KD says why.
            if request.live:
                request.abort(f"line server: {exc}")
            return
        except RobostarError as exc:
            self._refuse(request, f"line server: {exc}", _FLAG_FAILED)
            return
        except Exception as exc:  # a bug: the host still gets an answer, never silence
            log.exception("line %s: %s from %s failed", self.line.name, command.CODE, who.name)
            self._refuse(
                request, f"line server: internal error ({type(exc).__name__})", _FLAG_FAILED
            )
            return
        if not request.live:
            return
        request.answer(result)
        if request.two_phase:
            request.finish()

    def _refuse_held(self, request: Request, who: Who, error: LeaseHeldError) -> None:
        """0x32 for a lease refusal, its KD text saying so as the server's (not the
        controller's): the client reads it back as ControlHeldError (see robostar.errors)."""
        text = self._held_text(error)
        self.last_refusal = (time.time(), who, text)
        self._refuse(request, text, _FLAG_FAILED)

    def _held_text(self, error: LeaseHeldError) -> str:
        holder = error.holder
        if holder is None:
            return f"line server: {error}"
        return ControlHeldError.text_for(
            self.line.name, holder.who.name, holder.who.face, utc_clock(holder)
        )

    async def _last_error(self, request: Request) -> str:
        """KD for a session with no refusal of its own (``robostar last-error`` opens a new
        connection): the controller's text, and the server's last lease refusal on this line
        when recent, each said as whose it is, so the controller's "no error" does not stand
        alone after the server refused someone."""
        text = await self.line.read(request.command, who=self.who(request.session))
        refusal = self.last_refusal
        if refusal is None or time.time() - refusal[0] > RECENT_REFUSAL:
            return str(text)
        at, who, said = refusal
        clock = time.strftime("%H:%M:%S UTC", time.gmtime(at))
        both = f"controller: {text or 'no error'}; at {clock} {who.name} was refused by the {said}"
        return both[:MAX_TEXT]

    @staticmethod
    def _refuse(request: Request, reason: str, flag: int) -> None:
        if request.live:
            request.refuse(reason, flag)

    def session(self, name: str, timeout: float) -> ControllerSession:
        """A new N1 session on this backend (one per connection)."""
        return ControllerSession(self, name=name, timeout=timeout)

    def begin_upload(self, session: ControllerSession, command: UploadFile) -> None:
        """Refuse an FB before its lines are sent when another consumer, another N1 session
        included, holds the lease."""
        holder = self.line.lease.holder
        who = self.who(session)
        if holder is None or holder.who == who:
            return  # free (the upload takes it when it is carried out), or this session's
        error = LeaseHeldError(self.line.name, holder)
        self.line.record(command, who, f"refused: {error}")
        text = self._held_text(error)
        self.last_refusal = (time.time(), who, text)
        raise Refusal(text, _FLAG_FAILED)

    def exchange_abandoned(self, session: ControllerSession, request: Request) -> None:
        # nobody waits for its outcome now: a write of a host that moved on must not run,
        # whether it waits in the line's queue (withdrawn) or its task has not run yet
        self._abandoned.add(request)
        self._withdraw(session, _GAVE_UP)
        # The session follows its host, whatever the line is doing: the exchange ends now
        # (nothing is sent, the host has moved on) and the host's next request is taken at
        # once, queued behind what the line still does. Waiting for the line's answer instead
        # kept a host whose reply timeout is shorter than the line's out of step for good: by
        # the time the answer came, its next request had been given up too, and nothing was
        # left to answer that one.
        if request.live:
            request.abort(f"line server: {_GAVE_UP}")

    def session_closed(self, session: ControllerSession) -> None:
        self._withdraw(session, "its N1 connection closed")
        self.line.lease.release(self.who(session))

    def _withdraw(self, session: ControllerSession, why: str) -> None:
        """Take ``session``'s requests still waiting in the line's queue out of it."""
        withdrawn = self.line.withdraw(self.who(session), why)
        if withdrawn:
            log.info(
                "line %s: %d request(s) of %s withdrawn: %s",
                self.line.name,
                withdrawn,
                session.name,
                why,
            )

    async def drain(self) -> None:
        for task in list(self._tasks):
            task.cancel()
        if self._tasks:
            await asyncio.gather(*self._tasks, return_exceptions=True)
