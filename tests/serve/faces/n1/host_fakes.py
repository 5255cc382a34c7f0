"""A tiny backend for the asyncio host's tests: AA answered a little later, as a line server
would, everything else refused."""

from __future__ import annotations

import asyncio

from robostar import ChannelStatus
from robostar.commands.status import ReadStatus
from robostar.controller_role import Backend, ControllerSession, Refusal, Request
from robostar.protocol.fields import FLAG_UNSUPPORTED

STATUS = (ChannelStatus(servo_on=True), ChannelStatus(), ChannelStatus(alarm=True))


class LateStatus(Backend):
    """Answers AA from a fixed status a little later, from the event loop; refuses the rest.
    Notes the sessions it made (:meth:`session`, a host's factory) and those closed."""

    def __init__(self) -> None:
        self.made: list[str] = []
        self.closed: list[str] = []

    def session(self, name: str) -> ControllerSession:
        self.made.append(name)
        return ControllerSession(self, name=name)

    def handle(self, request: Request) -> None:
        if not isinstance(request.command, ReadStatus):
            raise Refusal(f"{request.command.CODE} is not served here", FLAG_UNSUPPORTED)
        asyncio.get_running_loop().call_later(0.01, request.answer, STATUS)

    def session_closed(self, session: ControllerSession) -> None:
        self.closed.append(session.name)
