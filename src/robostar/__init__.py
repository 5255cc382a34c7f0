"""robostar: the Robostar N1 robot controller host protocol for Python.

Open a controller and talk to it::

    from robostar import Client

    with Client("/dev/ttyUSB0") as robot:      # or "tcp://host:20000", or "sim://"
        print(robot.status())
        robot.home(1, wait=True)

:class:`AsyncClient` has the same methods for asyncio; :func:`probe` finds a port's baud rate.
The result types and every error are importable from here too.
"""

from robostar.client import (
    AlarmRaisedError,
    AsyncClient,
    Client,
    JogInterruptedError,
    ProbeResult,
    TraceRecord,
    WaitError,
    WaitTimeoutError,
    probe,
)
from robostar.errors import (
    AnswerTooLongError,
    ControlHeldError,
    ControllerError,
    FieldError,
    FrameError,
    FunctionFailedError,
    LineError,
    LinkResetError,
    LinkRuleError,
    MalformedAnswerError,
    NakLimitError,
    NotSupportedError,
    OutcomeUnknownError,
    PacketTooLongError,
    PortError,
    ProtocolError,
    RejectedError,
    ReplyTimeoutError,
    RobostarError,
    UploadIncompleteError,
    UsageError,
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
    GlobalKind,
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

__version__ = "0.2.0"

__all__ = [
    "Alarm",
    "AlarmRaisedError",
    "AlarmRecord",
    "AnswerTooLongError",
    "ArmForm",
    "AsyncClient",
    "ChannelInfo",
    "ChannelStatus",
    "Client",
    "ControlHeldError",
    "ControllerError",
    "ControllerInfo",
    "CoordSystem",
    "FieldError",
    "FileName",
    "FileRecord",
    "FrameError",
    "FunctionFailedError",
    "GlobalKind",
    "IOState",
    "JobFile",
    "JobMode",
    "JogDirection",
    "JogInterruptedError",
    "LineError",
    "LinkResetError",
    "LinkRuleError",
    "MalformedAnswerError",
    "MotionType",
    "NakLimitError",
    "NotSupportedError",
    "OutcomeUnknownError",
    "PacketTooLongError",
    "Point",
    "PointFile",
    "PortError",
    "Position",
    "PositionKind",
    "ProbeResult",
    "ProtocolError",
    "RejectedError",
    "ReplyTimeoutError",
    "RobostarError",
    "RobotType",
    "TraceRecord",
    "UploadIncompleteError",
    "UsageError",
    "WaitError",
    "WaitTimeoutError",
    "__version__",
    "probe",
]
