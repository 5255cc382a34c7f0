"""The history checker's consumers: seeded random operations through one face, each recorded.

:func:`next_op` draws an operation (a read or a state change, as a command object) from a
consumer's own random generator. A :class:`ClientConsumer` runs them through
:class:`robostar.Client` (an N1 face connection, or ``serve://``); an :class:`ApiConsumer`
through the JSON API. Both record an :class:`~reliability.history_judge.Op` per operation:
invocation and response times, and the value normalised as the judge compares it.
"""

from __future__ import annotations

import contextlib
import json
import random
import socket
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import robostar
from reliability.history_judge import FAILED, OK, REFUSED, UNKNOWN, Op
from robostar.commands import control, files, io, job, motion, status, variables
from robostar.commands.base import Command
from robostar.errors import (
    ControllerError,
    LineError,
    RobostarError,
    UsageError,
)
from robostar.protocol.frame import encode_packet
from robostar.sim.journal import file_digest, jsonable
from robostar.types import ChannelStatus, CoordSystem, JobFile, MotionType, PositionKind

__all__ = ["JOB_CHANNEL", "ApiConsumer", "ClientConsumer", "Plan", "next_op", "normalise"]

JOB_CHANNEL = 2
"""The channel whose selected job the consumers start and stop (its robot stays put)."""
GLOBALS = 8
"""Global variables 0..GLOBALS-1 are read and written."""


@dataclass(frozen=True)
class Planned:
    """One drawn operation: the command, whether to wait for the motion, the read's kind."""

    command: Command[Any]
    wait: bool = False
    kind: str = ""


@dataclass
class Plan:
    """A consumer's random choices (seeded) and its unique values for writes."""

    name: str
    index: int
    rng: random.Random
    counter: int = 0
    files: list[str] = field(default_factory=list)

    def unique(self) -> int:
        self.counter += 1
        return (self.index * 100_000 + self.counter) % 1_000_000


def _reads(plan: Plan) -> Planned:
    rng = plan.rng
    pick = rng.randrange(10)
    if pick == 0:
        return Planned(status.ReadStatus())
    if pick == 1:
        return Planned(status.ReadAlarms())
    if pick in (2, 3):
        return Planned(status.ReadPosition(rng.choice((1, 2)), PositionKind.ANGLE))
    if pick == 4:
        return Planned(control.ReadSpeed(rng.choice((1, 2))))
    if pick == 5:
        index = rng.randrange(GLOBALS)
        if rng.random() < 0.5:
            return Planned(variables.ReadGlobalInt(index), kind="int")
        return Planned(variables.ReadGlobalFloat(index), kind="float")
    if pick == 6:
        return Planned(io.ReadInputs(0))
    if pick == 7:
        return Planned(io.ReadOutputs(0))
    if pick == 8:
        return Planned(job.ReadJobStep(JOB_CHANNEL))
    name = f"H{rng.randrange(1, 6)}.JOB"
    return Planned(files.DownloadFile(1, name, CoordSystem.ANGLE))


def _writes(plan: Plan) -> Planned:
    rng = plan.rng
    pick = rng.randrange(16)
    wait = rng.random() < 0.5
    if pick in (0, 1):
        return Planned(variables.WriteGlobalInt(rng.randrange(GLOBALS), plan.unique()))
    if pick == 2:
        value = plan.unique() / 100
        return Planned(variables.WriteGlobalFloat(rng.randrange(GLOBALS), value))
    if pick == 3:
        return Planned(io.SetOutput(0, rng.randrange(16), rng.random() < 0.5))
    if pick == 4:
        return Planned(control.SetSpeed(rng.choice((1, 2)), rng.randrange(100, 1001)))
    if pick in (5, 6):
        target = (round(rng.uniform(-40, 40), 2), round(rng.uniform(-40, 40), 2), 0.0, 0.0)
        return Planned(motion.Move(1, MotionType.JOINT, CoordSystem.ANGLE, (target,)), wait)
    if pick == 7:
        delta = (round(rng.uniform(-10, 10), 2), round(rng.uniform(-10, 10), 2), 0.0, 0.0)
        return Planned(motion.MoveBy(1, MotionType.JOINT, CoordSystem.ANGLE, delta), wait)
    if pick == 8:
        # Past the soft limit: refused, and the controller raises alarm 9003.
        return Planned(
            motion.Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((500.0, 0.0, 0.0, 0.0),)), wait
        )
    if pick == 9:
        return Planned(control.ResetAlarms())
    if pick == 10:
        # After an emergency stop or a restart of the controller: origin return, job again.
        if rng.random() < 0.5:
            return Planned(control.ResetAlarms())
        if rng.random() < 0.5:
            return Planned(motion.Home(1), wait=True)
        return Planned(job.SelectJob(JOB_CHANNEL, "LOOP.JOB"))
    if pick == 11:
        return Planned(job.Servo(1, rng.random() < 0.8))
    if pick == 12:
        return Planned(control.StartJob(JOB_CHANNEL))
    if pick == 13:
        return Planned(control.StopJob(JOB_CHANNEL))
    if pick == 14:
        name = f"H{rng.randrange(1, 6)}.JOB"
        lines = ("MAIN", f"DELAY {plan.unique() % 100_000}", "EOP")
        return Planned(files.UploadFile(1, name, 0, lines))
    name = f"H{rng.randrange(1, 6)}.JOB"
    if rng.random() < 0.2:
        return Planned(control.EmergencyStop())
    return Planned(files.DeleteFile(1, name))


def next_op(plan: Plan, write_share: float = 0.3) -> Planned:
    return _writes(plan) if plan.rng.random() < write_share else _reads(plan)


def _args(planned: Planned) -> dict[str, Any]:
    args: dict[str, Any] = jsonable(planned.command)
    if planned.kind:
        args["kind"] = planned.kind
    return args


def normalise(command: Command[Any], result: Any) -> Any:
    """A read's result as the judge compares it with the journal."""
    if isinstance(command, status.ReadStatus):
        return [s.to_byte() for s in result]
    if isinstance(command, status.ReadAlarms):
        return [a.code for a in result]
    if isinstance(command, status.ReadPosition):
        return list(result.axes)
    if isinstance(command, io.ReadInputs | io.ReadOutputs):
        return sum(1 << i for i, on in enumerate(result.contacts) if on)
    if isinstance(command, files.DownloadFile):
        if result is None:
            return None
        if isinstance(result, JobFile):
            return file_digest(lines=result.lines)
        return file_digest(points=result.points)
    if isinstance(command, variables.ReadGlobalFloat):
        return float(result)
    return result


def _from_api(command: Command[Any], result: Any) -> Any:
    """The API's JSON result as the judge compares it."""
    if isinstance(command, status.ReadStatus):
        return [ChannelStatus(**s).to_byte() for s in result]
    if isinstance(command, io.ReadInputs | io.ReadOutputs):
        return sum(1 << i for i, on in enumerate(result["contacts"]) if on)
    return result


class _Consumer:
    """What both kinds share: the plan, the recorded ops, the stop flag."""

    face = ""

    def __init__(self, name: str, index: int, seed: int, ops: int, write_share: float) -> None:
        self.plan = Plan(name, index, random.Random(seed * 7919 + index))
        self.count = ops
        self.write_share = write_share
        self.ops: list[Op] = []
        self.stop = threading.Event()
        self.crash: BaseException | None = None
        self.more: Callable[[], bool] = lambda: False
        """Go on past ``count`` while this says so (the run's faults have not all begun)."""

    def run(self) -> None:
        try:
            seq = 0
            while seq < self.count or self.more():
                if self.stop.is_set():
                    return
                self.one(seq, next_op(self.plan, self.write_share))
                seq += 1
        except BaseException as exc:
            self.crash = exc
        finally:
            self.close()

    def one(self, seq: int, planned: Planned) -> None:
        raise NotImplementedError

    def close(self) -> None:
        pass

    def _op(self, seq: int, planned: Planned) -> Op:
        command = planned.command
        op = Op(
            self.plan.name,
            seq,
            command.CODE,
            _args(planned),
            command.CHANGES_STATE,
            time.monotonic(),
        )
        self.ops.append(op)
        return op


class ClientConsumer(_Consumer):
    """A host program on its own connection (an N1 face address, or ``serve://``), reconnecting
    after a line error and every ``reconnect_every`` ops (which gives its lease up)."""

    def __init__(
        self,
        name: str,
        index: int,
        seed: int,
        ops: int,
        url: Callable[[], str],
        *,
        timeout: float = 2.0,
        write_share: float = 0.3,
        reconnect_every: int = 8,
        drop_share: float = 0.0,
        raw_address: Callable[[], tuple[str, int]] | None = None,
    ) -> None:
        super().__init__(name, index, seed, ops, write_share)
        self.url = url
        self.timeout = timeout
        self.reconnect_every = reconnect_every
        self.drop_share = drop_share
        self.raw_address = raw_address
        self.client: robostar.Client | None = None

    def _connected(self) -> robostar.Client:
        if self.client is None:
            self.client = robostar.Client(self.url(), timeout=self.timeout)
        return self.client

    def close(self) -> None:
        if self.client is not None:
            with contextlib.suppress(RobostarError):
                self.client.close()
            self.client = None

    def one(self, seq: int, planned: Planned) -> None:
        if seq and seq % self.reconnect_every == 0:
            self.close()
        command = planned.command
        if (
            self.raw_address is not None
            and not isinstance(command, files.UploadFile)
            and self.plan.rng.random() < self.drop_share
        ):
            self._send_and_leave(seq, planned)
            return
        try:
            client = self._connected()
        except RobostarError:
            time.sleep(0.05)
            return  # not sent: no op
        op = self._op(seq, planned)
        try:
            result = client.execute(command)
            if planned.wait and isinstance(command, motion.Move | motion.MoveBy | motion.Home):
                # The move was answered: its outcome is known, however the wait ends.
                with contextlib.suppress(RobostarError):
                    client.wait_stopped(command.channel, timeout=5.0)
            op.outcome, op.value = OK, normalise(command, result)
        except ControllerError as exc:
            if isinstance(command, files.DownloadFile) and "no file" in str(exc):
                op.outcome, op.value = OK, None  # no such file: that is the answer
            else:
                op.outcome, op.error = (REFUSED if command.CHANGES_STATE else FAILED), str(exc)
        except UsageError as exc:
            op.outcome, op.error = FAILED, f"usage: {exc}"
        except (LineError, RobostarError, OSError) as exc:
            op.outcome = UNKNOWN if command.CHANGES_STATE else FAILED
            op.error = f"{type(exc).__name__}: {exc}"
            self.close()
        op.resp = time.monotonic()

    def _send_and_leave(self, seq: int, planned: Planned) -> None:
        """A host that sends its request and drops the connection before the answer (a host
        program killed mid-exchange): its own connection, so no order with the others."""
        assert self.raw_address is not None
        op = self._op(seq, planned)
        op.consumer = f"{self.plan.name}-gone{seq}"
        op.outcome = UNKNOWN if planned.command.CHANGES_STATE else FAILED
        op.error = "connection dropped mid-exchange"
        try:
            with socket.create_connection(self.raw_address(), timeout=2.0) as sock:
                sock.sendall(encode_packet(planned.command.encode()))
                time.sleep(self.plan.rng.uniform(0.0, 0.05))
        except OSError as exc:
            op.error = f"not sent: {exc}"
        op.resp = time.monotonic()


_API_COMMANDS = (
    status.ReadStatus,
    control.ReadSpeed,
    variables.ReadGlobalInt,
    io.ReadInputs,
    io.ReadOutputs,
    job.ReadJobStep,
    control.SetSpeed,
    variables.WriteGlobalInt,
    io.SetOutput,
    control.ResetAlarms,
)


class ApiConsumer(_Consumer):
    """A program on the JSON API (``POST /lines/LINE/commands``), taking the lease implicitly
    and giving it up every ``release_every`` ops; ``max_age`` asks for older values."""

    face = "api"

    def __init__(
        self,
        name: str,
        index: int,
        seed: int,
        ops: int,
        base: Callable[[], str],
        *,
        write_share: float = 0.3,
        release_every: int = 20,
        max_age: float | None = None,
    ) -> None:
        super().__init__(name, index, seed, ops, write_share)
        self.base = base
        self.release_every = release_every
        self.max_age = max_age

    def _post(self, path: str, body: dict[str, Any] | None, method: str = "POST") -> Any:
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(
            self.base() + path,
            data=data,
            method=method,
            headers={"Content-Type": "application/json", "X-Robostar-Who": self.plan.name},
        )
        with urllib.request.urlopen(request, timeout=10) as reply:
            return json.loads(reply.read())

    def one(self, seq: int, planned: Planned) -> None:
        if seq and seq % self.release_every == 0:
            with contextlib.suppress(OSError, ValueError):
                self._post("/lease", None, "DELETE")
        command = planned.command
        if not isinstance(command, _API_COMMANDS):
            return
        body: dict[str, Any] = {
            "command": type(command).__name__,
            "args": jsonable(command),
            "implicit_lease": True,
        }
        if self.max_age is not None and not command.CHANGES_STATE:
            body["max_age"] = self.max_age
        op = self._op(seq, planned)
        try:
            answer = self._post("/commands", body)
            op.outcome, op.value = OK, _from_api(command, answer["result"])
        except urllib.error.HTTPError as exc:
            detail = exc.read().decode("utf-8", "replace")[:200]
            op.error = f"HTTP {exc.code}: {detail}"
            if exc.code in (409, 422, 400):
                op.outcome = REFUSED if command.CHANGES_STATE else FAILED
            else:
                op.outcome = UNKNOWN if command.CHANGES_STATE else FAILED
        except (OSError, ValueError) as exc:
            op.outcome = UNKNOWN if command.CHANGES_STATE else FAILED
            op.error = f"{type(exc).__name__}: {exc}"
        op.resp = time.monotonic()
