"""One representative request and result for every command class, and its valid answer packets.

The fuzzers mutate these answers; the round trip (encode_answer then decode_answer) is the
sanity check that they are valid to begin with.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robostar.commands import (
    COMMANDS,
    Command,
    control,
    files,
    io,
    job,
    motion,
    status,
    system,
    variables,
)
from robostar.protocol.fields import FileName
from robostar.types import (
    Alarm,
    AlarmRecord,
    ArmForm,
    ChannelInfo,
    ChannelStatus,
    ControllerInfo,
    CoordSystem,
    FileRecord,
    IOState,
    JobFile,
    JobMode,
    JogDirection,
    MotionType,
    Point,
    PointFile,
    Position,
    PositionKind,
    RobotType,
)

__all__ = ["SAMPLES", "Sample"]

JOB = FileName("MAIN", "JOB")
PNT = FileName("MAIN", "PNT")
_POINT = Point((10.0, -20.5, 30.25, 0.0, 0.0, 0.0), ArmForm.LEFT, True)


@dataclass(frozen=True)
class Sample:
    """A request, a result it may be answered with, and that answer's packets."""

    command: Command[Any]
    result: Any

    @property
    def answer(self) -> list[bytes]:
        return self.command.encode_answer(self.result)


_STATUS = ChannelStatus(servo_on=True, origin=True, ready=True)
_INFO = ControllerInfo(
    2,
    "N1",
    "V1.00",
    (
        ChannelInfo(1, "RS-SCARA", RobotType.SCARA, 4, (1, 2, 3, 4)),
        ChannelInfo(2, "RS-XY", RobotType.XY, 2, (1, 2)),
        ChannelInfo(3, "", RobotType.NOT_DEFINED, 0, ()),
    ),
)
_HISTORY = (AlarmRecord(1, 1, 3, 4, 5, 6, 1, "T/P Emergency", "stop", 1153),)

SAMPLES: tuple[Sample, ...] = (
    Sample(status.ReadStatus(), (_STATUS, ChannelStatus(), ChannelStatus(alarm=True))),
    Sample(status.ReadAlarms(), (Alarm(1153, "T/P Emergency"), Alarm(1201, "Host Emergency"))),
    Sample(
        status.ReadPosition(1, PositionKind.XY),
        Position(PositionKind.XY, (1.5, -2.25), ArmForm.RIGHT),
    ),
    Sample(status.ReadInfo(), _INFO),
    Sample(motion.Home(1), None),
    Sample(motion.MoveToPoint(1, PNT, MotionType.JOINT, 5), None),
    Sample(motion.Move(1, MotionType.LINEAR, CoordSystem.XY, ((1.0, 2.0, 3.0, 4.0),)), None),
    Sample(motion.MoveBy(1, MotionType.JOINT, CoordSystem.ANGLE, (1.0, 0.0, 0.0, 0.0)), None),
    Sample(motion.JogStart(1, 1, JogDirection.PLUS, MotionType.JOINT), None),
    Sample(motion.JogContinue(1), None),
    Sample(motion.JogStop(1), None),
    Sample(control.ReadSpeed(1), 500),
    Sample(control.SetSpeed(1, 500), None),
    Sample(control.StartJob(1), None),
    Sample(control.StopJob(1), None),
    Sample(control.ResetJob(1), None),
    Sample(control.EmergencyStop(), None),
    Sample(control.ResetAlarms(), None),
    Sample(control.StopHoming(1), None),
    Sample(control.Restart(), None),
    Sample(control.SetReferenceAxis(1, 4), None),
    Sample(control.ReadReferenceAxis(1), 4),
    Sample(job.Servo(1, True), 2),
    Sample(job.SelectJob(1, JOB), 1),
    Sample(job.SetJobMode(1, JobMode.STEP), None),
    Sample(job.ReadJobStep(1), 27),
    Sample(job.ReadJobName(1), JOB),
    Sample(files.DownloadFile(1, JOB), JobFile(("MAIN", "MOVJ P1", "EOP"))),
    Sample(files.DownloadFile(1, PNT), PointFile({1: _POINT, 3: _POINT})),
    Sample(files.UploadFile(1, JOB, 1, ("MAIN", "EOP")), None),
    Sample(files.FileExists(1, JOB), True),
    Sample(files.ListFiles(1), (FileRecord(1, "MAIN.JOB", 1, 3), FileRecord(0, "MAIN.PNT", 2, 0))),
    Sample(files.DeleteFile(1, JOB), None),
    Sample(files.CopyFile(1, JOB, 1, FileName("COPY", "JOB")), None),
    Sample(files.RenameFile(1, JOB, FileName("NEW", "JOB")), None),
    Sample(files.ReadAlarmHistory(), _HISTORY),
    Sample(io.ReadInputs(0), IOState(0, tuple(i % 3 == 0 for i in range(16)))),
    Sample(io.ReadOutputs(1), IOState(1, tuple(i % 2 == 0 for i in range(16)))),
    Sample(io.SetOutput(1, 12, True), None),
    Sample(io.ReadIOBoards(), (1, 2)),
    Sample(variables.ReadGlobalPoint(1, 45), _POINT),
    Sample(variables.ReadGlobalInt(45), -1234),
    Sample(variables.ReadGlobalFloat(45), 12345.125),
    Sample(variables.WriteGlobalPoint(1, 45, _POINT), None),
    Sample(variables.WriteGlobalInt(45, 99), None),
    Sample(variables.WriteGlobalFloat(45, -1.5), None),
    Sample(system.ReadLastError(), "Servo is off"),
    Sample(system.ReadParameters(1), ("P1=100", "P2=200")),
)
"""Every command class at least once (FA twice: a JOB and a PNT file)."""


def _check_coverage() -> None:
    """A command added to the catalogue without a sample here would go unfuzzed: refuse."""
    covered = {type(sample.command) for sample in SAMPLES}
    missing = [
        cls.__name__ for classes in COMMANDS.values() for cls in classes if cls not in covered
    ]
    if missing:
        raise RuntimeError(f"reliability samples miss {', '.join(missing)}")


_check_coverage()
