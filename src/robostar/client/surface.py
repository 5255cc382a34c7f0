"""The command surface, written once: every client method as a plan, for both clients.

:class:`Operations` is mixed into :class:`~robostar.client.sync.Client` (methods block and
return results) and :class:`~robostar.client.aio.AsyncClient` (the same methods are coroutines).
Arguments are checked when a method is called, before anything is sent; mistakes raise
:class:`~robostar.errors.UsageError` (or its FieldError) naming the argument.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from typing import TypeVar

from robostar.backup import Manifest, RestoreDiff, backup_plan, restore_plan
from robostar.client import args
from robostar.client.binding import operation
from robostar.client.exchange import Progress
from robostar.client.files import download_job, download_points, file_name, point_lines, upload
from robostar.client.plan import Plan, call, sleep
from robostar.commands.base import Command
from robostar.commands.control import (
    EmergencyStop,
    ReadReferenceAxis,
    ReadSpeed,
    ResetAlarms,
    ResetJob,
    Restart,
    SetReferenceAxis,
    SetSpeed,
    StartJob,
    StopHoming,
    StopJob,
)
from robostar.commands.files import (
    CopyFile,
    DeleteFile,
    FileExists,
    ListFiles,
    ReadAlarmHistory,
    RenameFile,
)
from robostar.commands.io import ReadInputs, ReadIOBoards, ReadOutputs, SetOutput
from robostar.commands.job import ReadJobName, ReadJobStep, SelectJob, Servo, SetJobMode
from robostar.commands.motion import Home, Move, MoveBy, MoveToPoint
from robostar.commands.status import ReadAlarms, ReadInfo, ReadPosition, ReadStatus
from robostar.commands.system import ReadLastError, ReadParameters
from robostar.commands.variables import (
    ReadGlobalFloat,
    ReadGlobalInt,
    ReadGlobalPoint,
    WriteGlobalFloat,
    WriteGlobalInt,
    WriteGlobalPoint,
)
from robostar.errors import AlarmRaisedError, UsageError, WaitTimeoutError
from robostar.protocol.fields import FileName
from robostar.types import (
    Alarm,
    AlarmRecord,
    ChannelStatus,
    ControllerInfo,
    CoordSystem,
    FileRecord,
    IOState,
    JobFile,
    JobMode,
    MotionType,
    Point,
    PointFile,
    Position,
    PositionKind,
)

__all__ = ["DEFAULT_WAIT", "HOMING_WAIT", "AllStatus", "Operations", "PlanHelpers"]

R = TypeVar("R")
DEFAULT_WAIT = 60.0
"""Seconds a ``wait=True`` motion waits for the robot to stop."""
HOMING_WAIT = 120.0
"""Seconds ``home(wait=True)`` waits for the origin to be found."""

AllStatus = tuple[ChannelStatus, ChannelStatus, ChannelStatus]


def _stopped(status: ChannelStatus) -> bool:
    return status.in_position and not status.running


def _homed(status: ChannelStatus) -> bool:
    return status.origin and not status.running


class PlanHelpers:
    """What the plans use of the client besides its operations: waiting for the robot.

    Both clients inherit it; the plans run with the client as ``self``.
    """

    poll_interval: float = 0.1
    """Seconds between status reads while waiting for the robot."""

    def _wait(
        self, channel: int, timeout: float, done: Callable[[ChannelStatus], bool], what: str
    ) -> Plan[ChannelStatus]:
        number = args.channel(channel)
        limit = args.positive(timeout, "timeout")
        end = time.monotonic() + limit
        while True:
            status = (yield from call(ReadStatus()))[number - 1]
            if done(status):
                return status
            if status.alarm and not status.running:
                alarms = yield from call(ReadAlarms())
                text = "; ".join(str(a) for a in alarms) or "no alarm text"
                message = f"channel {number}: alarm while waiting for it to {what}: {text}"
                raise AlarmRaisedError(message, number, status, alarms)
            left = end - time.monotonic()
            if left <= 0:
                message = f"channel {number} did not {what} within {limit:g} s (status: {status})"
                raise WaitTimeoutError(message, number, status)
            yield from sleep(min(self.poll_interval, left))

    def _motion(
        self, command: Home | MoveToPoint | Move | MoveBy, wait: bool, timeout: float
    ) -> Plan[None]:
        args.boolean(wait, "wait")
        args.positive(timeout, "timeout")
        yield from call(command)
        if wait and isinstance(command, Home):
            yield from self._wait(command.channel, timeout, _homed, "finish homing")
        elif wait:
            yield from self._wait(command.channel, timeout, _stopped, "stop in position")


class Operations(PlanHelpers):
    """Every method of the client, written once as a plan. Channels are 1-3, as the pendant
    numbers them.

    These are the single source: ``tools/generate_faces.py`` writes each as a real method of
    :class:`~robostar.client.Client` (blocking) and :class:`~robostar.client.AsyncClient`
    (a coroutine), with this signature and docstring (``make generate``; a test fails when the
    generated files are stale).
    """

    # -- any command -----------------------------------------------------------------------
    @operation
    def execute(self, command: Command[R], progress: Progress | None = None) -> Plan[R]:
        """Run any command object (see :mod:`robostar.commands`) and return its result.

        ``progress(count, total)`` is called as a multi-packet exchange goes (packets read, or
        lines accepted by an upload; ``total`` when known), e.g. to say how far a transfer got."""
        if not isinstance(command, Command):
            raise UsageError(f"command: must be a robostar Command, not {command!r}")
        return (yield from call(command, progress))

    # -- status (A) ------------------------------------------------------------------------
    @operation
    def status(self) -> Plan[AllStatus]:
        """AA: the status of channels 1-3 (servo, origin, alarm, ready, in position, running)."""
        return (yield from call(ReadStatus()))

    @operation
    def alarms(self) -> Plan[tuple[Alarm, ...]]:
        """AB: the current alarms (up to 10)."""
        return (yield from call(ReadAlarms()))

    @operation
    def position(self, channel: int, kind: str | PositionKind = "xy") -> Plan[Position]:
        """AC: the channel's position: ``kind`` "xy" (mm), "angle" (degrees/mm) or "pulse"."""
        return (yield from call(ReadPosition(args.channel(channel), args.position_kind(kind))))

    @operation
    def info(self) -> Plan[ControllerInfo]:
        """AD: controller name, version, and each channel's model, type and axes."""
        return (yield from call(ReadInfo()))

    # -- waiting ---------------------------------------------------------------------------
    @operation
    def wait_stopped(self, channel: int, timeout: float = DEFAULT_WAIT) -> Plan[ChannelStatus]:
        """Poll AA until the channel is in position and not running; return that status.

        WaitTimeoutError after ``timeout`` seconds; AlarmRaisedError if the channel stops
        with an alarm.
        """
        return (yield from self._wait(channel, timeout, _stopped, "stop in position"))

    @operation
    def wait_homed(self, channel: int, timeout: float = HOMING_WAIT) -> Plan[ChannelStatus]:
        """Poll AA until the channel's origin is done and it is not running."""
        return (yield from self._wait(channel, timeout, _homed, "finish homing"))

    # -- motion (B) ------------------------------------------------------------------------
    @operation
    def home(self, channel: int, *, wait: bool = False, timeout: float = HOMING_WAIT) -> Plan[None]:
        """BA: return to the origin; ``wait=True`` waits until homing is done."""
        yield from self._motion(Home(args.channel(channel)), wait, timeout)

    @operation
    def move_to_point(
        self,
        channel: int,
        file: str | FileName,
        point: int,
        *,
        via: int | None = None,
        motion: str | MotionType | None = None,
        wait: bool = False,
        timeout: float = DEFAULT_WAIT,
    ) -> Plan[None]:
        """BB: move to local ``point`` of a PNT file.

        With ``via``, an arc through point ``via`` to ``point`` (``motion="circle"``: a circle
        through both). ``motion`` is "joint" (default without ``via``), "linear", "arc" or
        "circle".
        """
        kind = _path_motion(motion, via is not None)
        name = file_name(file, "file", "PNT")
        if via is None:
            command = MoveToPoint(args.channel(channel), name, kind, point)
        else:
            command = MoveToPoint(args.channel(channel), name, kind, via, point)
        yield from self._motion(command, wait, timeout)

    @operation
    def move(
        self,
        channel: int,
        target: Sequence[float],
        *,
        coords: str | CoordSystem = "angle",
        motion: str | MotionType | None = None,
        via: Sequence[float] | None = None,
        wait: bool = False,
        timeout: float = DEFAULT_WAIT,
    ) -> Plan[None]:
        """BC: move to ``target`` (one value per axis) in "angle" or "xy" coordinates.

        With ``via``, an arc through ``via`` to ``target`` (``motion="circle"``: a circle
        through both). ``motion`` is "joint" (default without ``via``), "linear", "arc" or
        "circle".
        """
        kind = _path_motion(motion, via is not None)
        goal = args.axes(target, "target")
        points = (goal,) if via is None else (args.axes(via, "via"), goal)
        command = Move(args.channel(channel), kind, args.coord_system(coords), points)
        yield from self._motion(command, wait, timeout)

    @operation
    def move_by(
        self,
        channel: int,
        delta: Sequence[float],
        *,
        coords: str | CoordSystem = "angle",
        motion: str | MotionType = "joint",
        wait: bool = False,
        timeout: float = DEFAULT_WAIT,
    ) -> Plan[None]:
        """BD: move by ``delta`` (one value per axis) from the current position."""
        kind = args.motion_type(motion)
        if kind not in (MotionType.JOINT, MotionType.LINEAR):
            raise UsageError(f"motion: a relative move is 'joint' or 'linear', not {motion!r}")
        step = args.axes(delta, "delta")
        command = MoveBy(args.channel(channel), kind, args.coord_system(coords), step)
        yield from self._motion(command, wait, timeout)

    # -- speed and job control (C) ---------------------------------------------------------
    @operation
    def speed(self, channel: int) -> Plan[int]:
        """CA: the channel's speed, 0-1000 (1000 = 100 %)."""
        return (yield from call(ReadSpeed(args.channel(channel))))

    @operation
    def set_speed(self, channel: int, value: int) -> Plan[None]:
        """CB: set the channel's speed, 0-1000 (1000 = 100 %)."""
        yield from call(SetSpeed(args.channel(channel), value))

    @operation
    def start_job(self, channel: int) -> Plan[None]:
        """CC: start the selected job (after homing)."""
        yield from call(StartJob(args.channel(channel)))

    @operation
    def stop_job(self, channel: int) -> Plan[None]:
        """CD: stop the running job."""
        yield from call(StopJob(args.channel(channel)))

    @operation
    def reset_job(self, channel: int) -> Plan[None]:
        """CE: set the job back to its first step (servo off only)."""
        yield from call(ResetJob(args.channel(channel)))

    @operation
    def emergency_stop(self) -> Plan[None]:
        """CF: online emergency stop (raises "Host Emergency"; reset_alarms() clears it)."""
        yield from call(EmergencyStop())

    @operation
    def reset_alarms(self) -> Plan[None]:
        """CG: reset the controller's alarms."""
        yield from call(ResetAlarms())

    @operation
    def stop_homing(self, channel: int) -> Plan[None]:
        """CI: stop homing."""
        yield from call(StopHoming(args.channel(channel)))

    @operation
    def restart(self) -> Plan[None]:
        """CJ: restart the controller (servo off only)."""
        yield from call(Restart())

    @operation
    def set_reference_axis(self, channel: int, axis: int) -> Plan[None]:
        """CX: make axis 1 or 4 the reference of interpolated moves (servo off only)."""
        yield from call(SetReferenceAxis(args.channel(channel), axis))

    @operation
    def reference_axis(self, channel: int) -> Plan[int]:
        """CZ: the reference axis of interpolated moves, 1 or 4."""
        return (yield from call(ReadReferenceAxis(args.channel(channel))))

    # -- servo and job (D, E) --------------------------------------------------------------
    @operation
    def servo(self, channel: int, on: bool) -> Plan[int]:
        """DB: servo on or off; returns when done, with the wait the controller announced."""
        return (yield from call(Servo(args.channel(channel), args.boolean(on, "on"))))

    @operation
    def select_job(self, channel: int, name: str | FileName) -> Plan[int]:
        """DC: select the JOB file the channel runs; returns the announced wait (s)."""
        file = file_name(name, "name", "JOB")
        return (yield from call(SelectJob(args.channel(channel), file)))

    @operation
    def set_step_mode(self, channel: int, step: bool) -> Plan[None]:
        """EA: step mode (hold after each step) or auto mode; only while no job runs."""
        mode = JobMode.STEP if args.boolean(step, "step") else JobMode.AUTO
        yield from call(SetJobMode(args.channel(channel), mode))

    @operation
    def job_step(self, channel: int) -> Plan[int]:
        """ED: the step number the job is at."""
        return (yield from call(ReadJobStep(args.channel(channel))))

    @operation
    def job_name(self, channel: int) -> Plan[FileName | None]:
        """EF: the selected job's name, or None."""
        return (yield from call(ReadJobName(args.channel(channel))))

    # -- files (F) -------------------------------------------------------------------------
    @operation
    def download_job(
        self, channel: int, name: str | FileName, *, progress: Progress | None = None
    ) -> Plan[JobFile]:
        """FA: a JOB file's steps. ``progress(done, total)`` is called per packet."""
        return (yield from download_job(args.channel(channel), name, progress))

    @operation
    def download_points(
        self,
        channel: int,
        name: str | FileName,
        *,
        coords: str | CoordSystem = "angle",
        progress: Progress | None = None,
    ) -> Plan[PointFile]:
        """FA: a PNT file's points, in "angle" or "xy" coordinates."""
        system = args.coord_system(coords)
        return (yield from download_points(args.channel(channel), name, system, progress))

    @operation
    def upload_job(
        self,
        channel: int,
        name: str | FileName,
        lines: Sequence[str],
        *,
        number: int | None = None,
        progress: Progress | None = None,
    ) -> Plan[None]:
        """FB: store a JOB file (its steps, MAIN to EOP), verified; UploadIncompleteError if
        it cannot be. ``number`` is the JOB number (default: the file's own, or a free one)."""
        file = file_name(name, "name", "JOB")
        yield from upload(args.channel(channel), file, lines, number, progress)

    @operation
    def upload_points(
        self,
        channel: int,
        name: str | FileName,
        points: PointFile | Mapping[int, Point],
        *,
        number: int | None = None,
        progress: Progress | None = None,
    ) -> Plan[None]:
        """FB: store a PNT file (angle data), verified like :meth:`upload_job`."""
        file = file_name(name, "name", "PNT")
        lines = point_lines(points)
        yield from upload(args.channel(channel), file, lines, number, progress)

    @operation
    def file_exists(self, channel: int, name: str | FileName) -> Plan[bool]:
        """FC: does the channel hold this file?"""
        return (yield from call(FileExists(args.channel(channel), file_name(name, "name"))))

    @operation
    def list_files(self, channel: int, pattern: str = "*") -> Plan[tuple[FileRecord, ...]]:
        """FD: one file's record, or every JOB and PNT file with ``"*"``."""
        return (yield from call(ListFiles(args.channel(channel), pattern)))

    @operation
    def delete_file(self, channel: int, name: str | FileName) -> Plan[None]:
        """FE: delete a JOB file."""
        yield from call(DeleteFile(args.channel(channel), file_name(name, "name")))

    @operation
    def copy_file(
        self,
        channel: int,
        name: str | FileName,
        new_name: str | FileName,
        *,
        to_channel: int | None = None,
    ) -> Plan[None]:
        """FF: copy a file (within its channel, as the controller requires)."""
        number = args.channel(channel)
        target = number if to_channel is None else args.channel(to_channel, "to_channel")
        source = file_name(name, "name")
        copy = CopyFile(number, source, target, file_name(new_name, "new_name"))
        yield from call(copy)

    @operation
    def rename_file(
        self, channel: int, name: str | FileName, new_name: str | FileName
    ) -> Plan[None]:
        """FG: rename a file."""
        old = file_name(name, "name")
        yield from call(RenameFile(args.channel(channel), old, file_name(new_name, "new_name")))

    @operation
    def alarm_history(self) -> Plan[tuple[AlarmRecord, ...]]:
        """FH: the stored alarm history."""
        return (yield from call(ReadAlarmHistory()))

    @operation
    def backup(
        self,
        folder: str | os.PathLike[str],
        *,
        progress: Progress | None = None,
        keep: int | None = None,
        replace: bool = False,
    ) -> Plan[Manifest]:
        """Save every JOB and PNT file of every channel to ``folder``, with manifest.json
        (swapped into place only when complete; ``keep=N``: timestamped generations;
        ``replace``: even a backup of another target, see
        :func:`robostar.backup.backup_plan`)."""
        target = getattr(self, "url", None)  # the client's URL, recorded in the manifest
        return (yield from backup_plan(folder, progress, keep, target=target, replace=replace))

    @operation
    def restore(
        self,
        folder: str | os.PathLike[str],
        *,
        progress: Progress | None = None,
        channels: Sequence[int] | None = None,
        only: str | None = None,
        dry_run: bool = False,
        confirm: Callable[[RestoreDiff], bool] | None = None,
        delete_extra: bool = False,
        ignore_identity: bool = False,
    ) -> Plan[Manifest]:
        """Upload what is new or changed from a :meth:`backup` after a preflight that writes
        nothing on any failure, then read each back and compare (see
        :func:`robostar.backup.restore_plan`)."""
        return (
            yield from restore_plan(
                folder,
                progress,
                channels=channels,
                only=only,
                dry_run=dry_run,
                confirm=confirm,
                delete_extra=delete_extra,
                ignore_identity=ignore_identity,
            )
        )

    # -- I/O (G) ---------------------------------------------------------------------------
    @operation
    def inputs(self, port: int) -> Plan[IOState]:
        """GA: the 16 input contacts of I/O port 0-4."""
        return (yield from call(ReadInputs(port)))

    @operation
    def outputs(self, port: int) -> Plan[IOState]:
        """GB: the 16 output contacts of I/O port 0-4."""
        return (yield from call(ReadOutputs(port)))

    @operation
    def set_output(self, port: int, contact: int, on: bool) -> Plan[None]:
        """GC: switch output ``contact`` (0-15) of ``port`` (0-4) on or off."""
        yield from call(SetOutput(port, contact, args.boolean(on, "on")))

    @operation
    def io_boards(self) -> Plan[tuple[int, int]]:
        """GD: the number of input and output I/O boards."""
        return (yield from call(ReadIOBoards()))

    # -- global variables (GR, GW) ---------------------------------------------------------
    @operation
    def read_global_point(
        self, channel: int, index: int, *, coords: str | CoordSystem = "angle", axis: int = 0
    ) -> Plan[Point]:
        """GR: global point ``index`` (0-1023): all axes, or one (``axis`` 1-6)."""
        system = args.coord_system(coords)
        command = ReadGlobalPoint(args.channel(channel), index, system, axis)
        return (yield from call(command))

    @operation
    def read_global_int(self, index: int) -> Plan[int]:
        """GR: global integer ``index`` (0-499)."""
        return (yield from call(ReadGlobalInt(index)))

    @operation
    def read_global_float(self, index: int) -> Plan[float]:
        """GR: global float ``index`` (0-499)."""
        return (yield from call(ReadGlobalFloat(index)))

    @operation
    def write_global_point(
        self,
        channel: int,
        index: int,
        point: Point | Sequence[float],
        *,
        coords: str | CoordSystem = "angle",
        axis: int = 0,
    ) -> Plan[None]:
        """GW: write global point ``index`` (a Point, or axis values)."""
        value = point if isinstance(point, Point) else Point(args.axes(point, "point"))
        system = args.coord_system(coords)
        command = WriteGlobalPoint(args.channel(channel), index, value, system, axis)
        yield from call(command)

    @operation
    def write_global_int(self, index: int, value: int) -> Plan[None]:
        """GW: write global integer ``index`` (0-499)."""
        yield from call(WriteGlobalInt(index, value))

    @operation
    def write_global_float(self, index: int, value: float) -> Plan[None]:
        """GW: write global float ``index`` (0-499)."""
        yield from call(WriteGlobalFloat(index, value))

    # -- system (K) ------------------------------------------------------------------------
    @operation
    def last_error(self) -> Plan[str]:
        """KD: why the last command failed (0x32)."""
        return (yield from call(ReadLastError()))

    @operation
    def parameters(self, channel: int | None, index: int = -1) -> Plan[tuple[str, ...]]:
        """KE: a channel's parameter data (``None``: the public parameters); ``index`` -1
        for all of it, 1-99 for one group."""
        number = None if channel is None else args.channel(channel)
        return (yield from call(ReadParameters(number, index)))


def _path_motion(motion: str | MotionType | None, has_via: bool) -> MotionType:
    """The motion type of a move, checked against whether it has a via point."""
    if motion is None:
        return MotionType.ARC if has_via else MotionType.JOINT
    kind = args.motion_type(motion)
    needs_via = kind in (MotionType.ARC, MotionType.CIRCLE)
    if needs_via and not has_via:
        raise UsageError(f"via: a {kind.name.lower()} move needs a via point")
    if has_via and not needs_via:
        raise UsageError(f"via: only an arc or circle move takes a via point, not {motion!r}")
    return kind
