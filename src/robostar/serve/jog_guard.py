"""The jogs running on a line, and who keeps each alive: a jog nobody will keep alive (its
holder lost the lease, its start's outcome is unknown, the server stops) is stopped with BG
rather than left to the controller's watchdog."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import Any

from robostar.commands.base import Command
from robostar.commands.control import EmergencyStop
from robostar.commands.motion import JogStart, JogStop
from robostar.errors import OutcomeUnknownError, RobostarError
from robostar.serve.lease import Who

__all__ = ["JogGuard"]


class JogGuard:
    """Follows JogStart/JogStop/EmergencyStop outcomes; stops the jogs nobody keeps alive."""

    def __init__(
        self,
        send_stop: Callable[[int], Awaitable[None]],
        record: Callable[[Command[Any], Who, str], None],
        can_send: Callable[[], bool],
    ) -> None:
        """``send_stop(channel)`` sends BG ahead of everything; ``record`` audits; ``can_send``
        says whether the line takes requests now (up, and not stopping)."""
        self._send_stop = send_stop
        self._record = record
        self._can_send = can_send
        self.jogs: dict[int, Who] = {}
        """Channel -> who started its running jog."""

    def carried_out(self, command: Command[Any], who: Who) -> None:
        """``command`` of ``who`` was carried out."""
        if isinstance(command, JogStart):
            self.jogs[command.channel] = who
        elif isinstance(command, JogStop):
            self.jogs.pop(command.channel, None)
        elif isinstance(command, EmergencyStop):
            self.jogs.clear()

    def failed(self, command: Command[Any], who: Who, error: BaseException | str) -> None:
        """``command`` of ``who`` ended with ``error`` (or an audit outcome): a jog start whose
        outcome is unknown may have set the axis moving, and nobody will keep it alive: stop it
        now rather than leave it to the controller's watchdog."""
        unsure = (
            error.startswith("outcome unknown")
            if isinstance(error, str)
            else isinstance(error, OutcomeUnknownError)
        )
        if isinstance(command, JogStart) and unsure:
            self._stop_soon(command.channel, who, "its start's outcome was unknown")

    def lease_lost(self, who: Who) -> None:
        """``who`` lost the lease: its jogs are stopped."""
        for channel, holder in list(self.jogs.items()):
            if holder == who and self._stop_soon(channel, who, "lease lost"):
                self.jogs.pop(channel, None)

    def _stop_soon(self, channel: int, who: Who, why: str) -> bool:
        """BG for ``channel`` from a task of its own (audited with ``why``), while the line
        takes requests; False when not sent (a jog kept in ``jogs`` is then stopped as the
        server stops)."""
        if not self._can_send():
            return False
        task = asyncio.get_running_loop().create_task(self._stop(channel, who, why))
        task.add_done_callback(_ignore_result)
        return True

    async def _stop(self, channel: int, who: Who, why: str) -> None:
        try:
            await self._send_stop(channel)
        except RobostarError as exc:
            self._record(JogStop(channel), who, f"error: {why}, jog stop failed: {exc}")
            raise
        self._record(JogStop(channel), who, f"jog stopped: {why}")


def _ignore_result(task: asyncio.Task[Any]) -> None:
    if not task.cancelled():
        task.exception()
