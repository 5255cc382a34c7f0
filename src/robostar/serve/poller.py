"""The poller: keeps a line's model fresh for the push faces (MQTT, OPC UA, the web page,
metrics), reading through the line's read flights like any consumer.

A cycle reads the status and positions every ``poll_interval``; speed, job, step, alarms and I/O
every ``slow_interval`` (and at once after a state change); the alarm history every
``history_interval``. Its reads are flights of :class:`~robostar.serve.reads.ReadFlights`, so a
consumer's read waiting with one is answered by it and every consumer's read refreshes the
model too (as Home Assistant's DataUpdateCoordinator serves its entities). They wait behind the
consumers' requests until the model would go stale waiting, then take their place among them
(first come, first served), so that no number of readers can starve it. A value a consumer's
read refreshed within half a poll interval (and after the last state change) is not read again
by the cycle: hosts polling AA keep ``ch{n}/status`` fresh, and the wire's time goes to what
nobody else reads. Nor is a value the status vouches for (the positions of a channel at rest,
see :mod:`robostar.serve.status_witness`): it was confirmed by that status read.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Callable
from typing import Any, cast

from robostar.commands.base import Command
from robostar.commands.control import ReadSpeed
from robostar.commands.files import ReadAlarmHistory
from robostar.commands.io import ReadInputs, ReadOutputs
from robostar.commands.job import ReadJobName, ReadJobStep
from robostar.commands.status import ReadAlarms, ReadPosition, ReadStatus
from robostar.errors import ControllerError, NotSupportedError, RobostarError
from robostar.serve.config import LineConfig
from robostar.serve.line_errors import LineDownError
from robostar.serve.line_health import LineHealth
from robostar.serve.line_queue import PRI_LATE_POLL, PRI_POLL
from robostar.serve.model import ControllerModel
from robostar.serve.model_keys import keys_of, model_key
from robostar.serve.reads import ReadFlights
from robostar.types import PositionKind

__all__ = ["CONTENTION_WINDOW", "STEADY_KEYS", "Poller", "stale_after"]

log = logging.getLogger("robostar.serve")

CONTENTION_WINDOW = 1.0
"""Seconds after a consumer's read during which the poller keeps to its share of the wire."""
STEADY_KEYS = frozenset(("info", "online"))
"""Model values set when the line opens or closes, not by the poller."""


def stale_after(config: LineConfig) -> float:
    """Seconds without a complete poll after which the model's values are no longer vouched
    for (marked STALE), and the poller's reads queue with the consumers' requests."""
    return max(5 * config.poll_interval, 2 * config.slow_interval)


class Poller:
    """The poll cycle of one line (see the module docstring)."""

    def __init__(
        self,
        config: LineConfig,
        model: ControllerModel,
        health: LineHealth,
        reads: ReadFlights,
        *,
        recent: Callable[[Command[Any], float], bool] = lambda command, age: False,
        up: asyncio.Event,
        check_open: Callable[[], None],
        channels: Callable[[], tuple[int, ...]],
    ) -> None:
        self.config = config
        self.model = model
        self.health = health
        self.reads = reads
        self._up = up
        self._check_open = check_open
        self._channels = channels
        self._recent = recent
        self.unsupported: set[str] = set()
        """Poll reads the controller answered 0x33 (not supported): not asked again until the
        line reopens (by :func:`model_key`, else the command's code)."""
        self._poll_now = asyncio.Event()
        self._reread_all = False
        """A state change of unknown reach went out: the next pass reads everything."""
        self._reread_keys: set[str] = set()
        """Model keys narrow state changes may have changed: the next pass reads them."""
        self._consumer_at = -math.inf
        """``time.monotonic()`` of the last consumer read (see :meth:`consumer_read`)."""

    def state_changed(self, changed: frozenset[str] | None = None) -> None:
        """A state change went out: read again at once what it may have changed, so
        subscribers see its effect promptly: ``changed`` model keys (beyond status and
        positions, which a narrow change such as a speed leaves alone), or everything (None:
        the default, and what a refused change or one of unknown outcome gets)."""
        if changed is None:
            self._reread_all = True
        else:
            self._reread_keys |= changed
        self._poll_now.set()

    def consumer_read(self) -> None:
        """A consumer's read is waiting for the line: the poller keeps to its share of the wire
        for a while (see :attr:`LineConfig.poll_share`)."""
        self._consumer_at = time.monotonic()

    def line_opened(self) -> None:
        """The line may lead to another controller (or the same one reconfigured) now: what it
        did not support before is asked again."""
        self.unsupported.clear()

    async def run(self) -> None:
        next_cycle = 0.0
        next_slow = 0.0
        next_history = 0.0
        while True:
            await self._up.wait()
            started = time.monotonic()
            # cleared as the cycle starts, not as it ends: a write that lands during the cycle
            # sets it again and the next cycle starts at once (it would be lost otherwise)
            self._poll_now.clear()
            reread_all, reread = self._reread_all, self._reread_keys
            self._reread_all, self._reread_keys = False, set()
            cycle = started >= next_cycle or reread_all
            try:
                commands: list[Command[Any]] = []
                if cycle:
                    next_cycle = started + self.config.poll_interval
                    commands.append(ReadStatus())
                    for ch in self._channels():
                        commands.append(ReadPosition(ch, PositionKind.XY))
                        commands.append(ReadPosition(ch, PositionKind.ANGLE))
                if started >= next_slow or reread_all:
                    next_slow = started + self.config.slow_interval
                    commands += self._slow_reads()
                elif reread:
                    # a narrow change (a speed, an output): only what it may have changed
                    commands += [c for c in self._slow_reads() if keys_of(c) & reread]
                if started >= next_history:
                    next_history = started + self.config.history_interval
                    commands.append(ReadAlarmHistory())
                for command in commands:
                    await self._poll_one(command)
                if cycle:
                    self.health.last_poll = time.time()
            except LineDownError:
                await asyncio.sleep(0.05)
                continue
            except RobostarError as exc:
                log.debug("line %s poll: %s", self.config.name, exc)
                # the values are what they were, but nobody can vouch for them now; "online"
                # and "info" are the line's own, set as it opens or drops (a poll failing as
                # the line dropped made its "online: false" stale)
                self.model.age_out(math.inf, keep=STEADY_KEYS)
            delay = next_cycle - time.monotonic()
            # asyncio.wait, not wait_for: on Python 3.11 wait_for can swallow a cancellation
            # that races with the event, and stop() would wait forever for the poller.
            waiter = asyncio.ensure_future(self._poll_now.wait())
            try:
                await asyncio.wait({waiter}, timeout=max(0.0, delay))
            finally:
                waiter.cancel()

    def _slow_reads(self) -> list[Command[Any]]:
        """Speed, job, step, alarms and I/O: read every ``slow_interval``."""
        slow: list[Command[Any]] = [ReadAlarms()]
        for ch in self._channels():
            slow += [ReadSpeed(ch), ReadJobName(ch), ReadJobStep(ch)]
        for port in self.config.io_ports:
            slow += [ReadInputs(port), ReadOutputs(port)]
        return slow

    async def watch_staleness(self) -> None:
        """Mark the model's good values STALE while no poll has completed for a while (a
        starved or stuck poller): a value nobody re-read must not keep saying "good"."""
        limit = stale_after(self.config)
        while True:
            await asyncio.sleep(self.config.poll_interval)
            age = self.health.poll_age
            if self._up.is_set() and age is not None and age > limit:
                self.model.age_out(time.time() - limit, keep=STEADY_KEYS)

    async def _poll_one(self, command: Command[Any]) -> None:
        key = model_key(command) or command.CODE
        if key in self.unsupported:
            return
        if self._recent(command, self.config.poll_interval / 2):
            return  # a consumer's read refreshed it moments ago: the wire has better to do
        try:
            began = await self._poll_read(command)
        except NotSupportedError as exc:
            # 0x33: a channel without a robot, an option the controller lacks: stop asking. The
            # value it had (if any) is not vouched for any more.
            log.info("line %s: %s not polled any more (%s)", self.config.name, key, exc)
            self.unsupported.add(key)
            self._mark_stale(command)
            return
        except ControllerError as exc:
            # 0x31/0x32 ("cannot be done now"): a refusal of this moment, not of the value: ask
            # again next cycle; meanwhile the old value must not say "good"
            log.debug("line %s: poll of %s refused (%s)", self.config.name, key, exc)
            self._mark_stale(command)
            return
        await self._give_way(time.time() - began)

    async def _give_way(self, wire_time: float) -> None:
        """While consumers read, keep the poller's wire time to ``poll_share`` of the line's:
        after an exchange of ``wire_time`` seconds, wait ``wire_time * (1 - share) / share``
        (an exchange on the wire cannot be interrupted, so a host's read arriving during a long
        poll read waits for its end: on a slow line that is the hosts' latency). Never while
        the model is half-way to stale, nor past that point (its freshness comes first then):
        a small share after a long read would otherwise wait longer than the model may go
        unrefreshed."""
        share = self.config.poll_share
        if share >= 1.0 or math.isnan(wire_time) or wire_time <= 0:
            return
        if time.monotonic() - self._consumer_at > CONTENTION_WINDOW:
            return
        room = stale_after(self.config) / 2 - (self.health.poll_age or 0.0)
        if room <= 0:
            return
        await asyncio.sleep(min(wire_time * (1.0 - share) / share, room))

    def _mark_stale(self, command: Command[Any]) -> None:
        """Mark STALE the good model values that ``command`` (a poll read) refreshes."""
        keys = keys_of(command)
        if keys:
            # the model marks by age, not by key: every other key is kept out of it
            others = self.model.snapshot().keys() - keys
            self.model.age_out(math.inf, keep=others)

    async def _poll_read(self, command: Command[Any]) -> float:
        """A poll read, a flight like a consumer's (its answer refreshes the model): behind
        the consumers' requests, until the model would go stale waiting; from then on among
        them, in the order of arrival. The ``time.time()`` its exchange began."""
        limit = stale_after(self.config)
        age = self.health.poll_age or 0.0
        self._check_open()
        late = age > limit
        answer = self.reads.read(command, PRI_LATE_POLL if late else PRI_POLL, None)
        if not late:
            try:
                done, _ = await asyncio.wait({answer}, timeout=limit - age)
            except asyncio.CancelledError:
                answer.cancel()
                raise
            if not done:
                self.reads.hurry(command, PRI_LATE_POLL)
        _, began = await answer  # cancelled with the poller: the flight drops it
        return cast(float, began)

    async def wait_polled(self, timeout: float = 5.0) -> None:
        """Wait until a complete poll cycle has ended after now (tests, the CLI's start-up)."""
        since = time.time()

        async def cycle() -> None:
            while self.health.last_poll is None or self.health.last_poll < since:
                await asyncio.sleep(0.01)

        await asyncio.wait_for(cycle(), timeout)
