"""One handler per command class: a decoded request in, what to answer out.

A handler calls the model and returns a :class:`Reply` (the result the command class encodes),
a :class:`Deferred` (a two-phase command: the work finishes later, in model time) or an
:class:`Upload` (FB: the controller takes the file's lines next). A broken controller rule is
:class:`~robostar.sim.model.Refused`, raised by the model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from robostar.commands import control, files, io, job, motion, status, system, variables
from robostar.commands.base import Command
from robostar.protocol.fields import FileName
from robostar.sim.model import Model
from robostar.types import ChannelInfo, ControllerInfo, RobotType

__all__ = ["HANDLERS", "Deferred", "Outcome", "Reply", "Upload", "handle"]


@dataclass(frozen=True, slots=True)
class Reply:
    """Answer now with ``result``, encoded by the command class."""

    result: Any = None


@dataclass(frozen=True, slots=True)
class Deferred:
    """Two-phase: answer now, then again when ``finish`` has run ``duration`` model seconds on.

    ``wait`` is the manual's expected wait for the first answer (DB 2 s, DC 20 s; None for CE,
    whose first answer has none); the controller sends a smaller one when the work is quicker.
    """

    duration: float
    wait: int | None
    finish: Callable[[], None]


@dataclass(frozen=True, slots=True)
class Upload:
    """FB accepted: the file's lines follow."""

    channel: int
    file: FileName
    job_number: int


Outcome = Reply | Deferred | Upload


def _info(model: Model) -> ControllerInfo:
    channels = []
    for number in range(1, 4):
        if number <= len(model.channels):
            cfg = model.channel(number).cfg
            robot = cfg.can_move
            axes = tuple(range(1, cfg.axes + 1)) if robot else ()
            channels.append(
                ChannelInfo(number, cfg.model, cfg.robot, cfg.axes if robot else 0, axes)
            )
        else:
            channels.append(ChannelInfo(number, "", RobotType.NOT_DEFINED, 0, ()))
    # The served version, never the configured one: it carries the simulator's mark.
    return ControllerInfo(
        len(model.channels), model.config.name, model.config.served_version, tuple(channels)
    )


# -- status (A) --------------------------------------------------------------------------------
def _aa(model: Model, cmd: status.ReadStatus) -> Outcome:
    return Reply(model.status())


def _ab(model: Model, cmd: status.ReadAlarms) -> Outcome:
    return Reply(model.alarms.alarms())


def _ac(model: Model, cmd: status.ReadPosition) -> Outcome:
    return Reply(model.position(cmd.channel, cmd.kind))


def _ad(model: Model, cmd: status.ReadInfo) -> Outcome:
    return Reply(_info(model))


# -- motion (B) --------------------------------------------------------------------------------
def _ba(model: Model, cmd: motion.Home) -> Outcome:
    model.home(cmd.channel)
    return Reply()


def _bb(model: Model, cmd: motion.MoveToPoint) -> Outcome:
    model.move_to_point(cmd.channel, cmd.file, cmd.motion, cmd.point, cmd.point2)
    return Reply()


def _bc(model: Model, cmd: motion.Move) -> Outcome:
    model.move(cmd.channel, cmd.motion, cmd.coords, cmd.points)
    return Reply()


def _bd(model: Model, cmd: motion.MoveBy) -> Outcome:
    model.move_by(cmd.channel, cmd.motion, cmd.coords, cmd.delta)
    return Reply()


def _be(model: Model, cmd: motion.JogStart) -> Outcome:
    model.start_jog(cmd.channel, cmd.axis, cmd.direction, cmd.motion)
    return Reply()


def _bf(model: Model, cmd: motion.JogContinue) -> Outcome:
    model.continue_jog(cmd.channel)
    return Reply()


def _bg(model: Model, cmd: motion.JogStop) -> Outcome:
    model.stop_jog(cmd.channel)
    return Reply()


# -- control (C) -------------------------------------------------------------------------------
def _ca(model: Model, cmd: control.ReadSpeed) -> Outcome:
    return Reply(model.channel(cmd.channel).speed)


def _cb(model: Model, cmd: control.SetSpeed) -> Outcome:
    model.set_speed(cmd.channel, cmd.speed)
    return Reply()


def _cc(model: Model, cmd: control.StartJob) -> Outcome:
    model.start_job(cmd.channel)
    return Reply()


def _cd(model: Model, cmd: control.StopJob) -> Outcome:
    model.stop_job(cmd.channel)
    return Reply()


def _ce(model: Model, cmd: control.ResetJob) -> Outcome:
    duration, finish = model.reset_job(cmd.channel)
    return Deferred(duration, None, finish)


def _cf(model: Model, cmd: control.EmergencyStop) -> Outcome:
    model.emergency_stop()
    return Reply()


def _cg(model: Model, cmd: control.ResetAlarms) -> Outcome:
    model.reset_alarms()
    return Reply()


def _ci(model: Model, cmd: control.StopHoming) -> Outcome:
    model.stop_homing(cmd.channel)
    return Reply()


def _cj(model: Model, cmd: control.Restart) -> Outcome:
    model.restart()
    return Reply()


def _cx(model: Model, cmd: control.SetReferenceAxis) -> Outcome:
    model.set_reference_axis(cmd.channel, cmd.axis)
    return Reply()


def _cz(model: Model, cmd: control.ReadReferenceAxis) -> Outcome:
    return Reply(model.channel(cmd.channel).reference_axis)


# -- job (D, E) --------------------------------------------------------------------------------
def _db(model: Model, cmd: job.Servo) -> Outcome:
    duration, finish = model.servo(cmd.channel, cmd.on)
    return Deferred(duration, 2, finish)


def _dc(model: Model, cmd: job.SelectJob) -> Outcome:
    duration, finish = model.select_job(cmd.channel, cmd.file)
    return Deferred(duration, 20, finish)


def _ea(model: Model, cmd: job.SetJobMode) -> Outcome:
    model.set_job_mode(cmd.channel, cmd.mode)
    return Reply()


def _ed(model: Model, cmd: job.ReadJobStep) -> Outcome:
    return Reply(model.job_step(cmd.channel))


def _ef(model: Model, cmd: job.ReadJobName) -> Outcome:
    return Reply(model.channel(cmd.channel).job_name)


# -- files (F) ---------------------------------------------------------------------------------
def _fa(model: Model, cmd: files.DownloadFile) -> Outcome:
    return Reply(model.download(cmd.channel, cmd.file, cmd.coords))


def _fb(model: Model, cmd: files.UploadFile) -> Outcome:
    model.check_upload(cmd.channel, cmd.file, cmd.job_number)
    return Upload(cmd.channel, cmd.file, cmd.job_number)


def _fc(model: Model, cmd: files.FileExists) -> Outcome:
    return Reply(model.exists(cmd.channel, cmd.file))


def _fd(model: Model, cmd: files.ListFiles) -> Outcome:
    return Reply(model.list_files(cmd.channel, cmd.pattern))


def _fe(model: Model, cmd: files.DeleteFile) -> Outcome:
    model.delete(cmd.channel, cmd.file)
    return Reply()


def _ff(model: Model, cmd: files.CopyFile) -> Outcome:
    model.copy(cmd.channel, cmd.file, cmd.to_channel, cmd.to_file)
    return Reply()


def _fg(model: Model, cmd: files.RenameFile) -> Outcome:
    model.rename(cmd.channel, cmd.file, cmd.new_file)
    return Reply()


def _fh(model: Model, cmd: files.ReadAlarmHistory) -> Outcome:
    return Reply(model.alarms.records())


# -- I/O (G) -----------------------------------------------------------------------------------
def _ga(model: Model, cmd: io.ReadInputs) -> Outcome:
    return Reply(model.read_inputs(cmd.port))


def _gb(model: Model, cmd: io.ReadOutputs) -> Outcome:
    return Reply(model.read_outputs(cmd.port))


def _gc(model: Model, cmd: io.SetOutput) -> Outcome:
    model.set_output(cmd.port, cmd.contact, cmd.on)
    return Reply()


def _gd(model: Model, cmd: io.ReadIOBoards) -> Outcome:
    return Reply(model.config.io_boards)


# -- globals (GR, GW) --------------------------------------------------------------------------
def _gr_point(model: Model, cmd: variables.ReadGlobalPoint) -> Outcome:
    return Reply(model.read_global_point(cmd.channel, cmd.index, cmd.coords, cmd.axis))


def _gr_int(model: Model, cmd: variables.ReadGlobalInt) -> Outcome:
    return Reply(model.read_global_int(cmd.index))


def _gr_float(model: Model, cmd: variables.ReadGlobalFloat) -> Outcome:
    return Reply(model.read_global_float(cmd.index))


def _gw_point(model: Model, cmd: variables.WriteGlobalPoint) -> Outcome:
    model.write_global_point(cmd.channel, cmd.index, cmd.point, cmd.coords, cmd.axis)
    return Reply()


def _gw_int(model: Model, cmd: variables.WriteGlobalInt) -> Outcome:
    model.write_global_int(cmd.index, cmd.value)
    return Reply()


def _gw_float(model: Model, cmd: variables.WriteGlobalFloat) -> Outcome:
    model.write_global_float(cmd.index, cmd.value)
    return Reply()


# -- system (K) --------------------------------------------------------------------------------
def _kd(model: Model, cmd: system.ReadLastError) -> Outcome:
    return Reply(model.last_error)


def _ke(model: Model, cmd: system.ReadParameters) -> Outcome:
    return Reply(model.parameters(cmd.channel, cmd.index))


HANDLERS: dict[type[Command[Any]], Callable[[Model, Any], Outcome]] = {
    status.ReadStatus: _aa,
    status.ReadAlarms: _ab,
    status.ReadPosition: _ac,
    status.ReadInfo: _ad,
    motion.Home: _ba,
    motion.MoveToPoint: _bb,
    motion.Move: _bc,
    motion.MoveBy: _bd,
    motion.JogStart: _be,
    motion.JogContinue: _bf,
    motion.JogStop: _bg,
    control.ReadSpeed: _ca,
    control.SetSpeed: _cb,
    control.StartJob: _cc,
    control.StopJob: _cd,
    control.ResetJob: _ce,
    control.EmergencyStop: _cf,
    control.ResetAlarms: _cg,
    control.StopHoming: _ci,
    control.Restart: _cj,
    control.SetReferenceAxis: _cx,
    control.ReadReferenceAxis: _cz,
    job.Servo: _db,
    job.SelectJob: _dc,
    job.SetJobMode: _ea,
    job.ReadJobStep: _ed,
    job.ReadJobName: _ef,
    files.DownloadFile: _fa,
    files.UploadFile: _fb,
    files.FileExists: _fc,
    files.ListFiles: _fd,
    files.DeleteFile: _fe,
    files.CopyFile: _ff,
    files.RenameFile: _fg,
    files.ReadAlarmHistory: _fh,
    io.ReadInputs: _ga,
    io.ReadOutputs: _gb,
    io.SetOutput: _gc,
    io.ReadIOBoards: _gd,
    variables.ReadGlobalPoint: _gr_point,
    variables.ReadGlobalInt: _gr_int,
    variables.ReadGlobalFloat: _gr_float,
    variables.WriteGlobalPoint: _gw_point,
    variables.WriteGlobalInt: _gw_int,
    variables.WriteGlobalFloat: _gw_float,
    system.ReadLastError: _kd,
    system.ReadParameters: _ke,
}
"""Every command class of the catalogue and its handler."""


def handle(model: Model, command: Command[Any]) -> Outcome:
    """Carry out a decoded request; raises Refused when a controller rule says no."""
    return HANDLERS[type(command)](model, command)
