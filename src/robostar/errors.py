"""The one exception tree of robostar.

Every error robostar raises is a :class:`RobostarError`. The tree splits errors the caller caused
(refused before anything reaches the wire) from errors the controller or the line caused::

    RobostarError
    ├── UsageError (ValueError)             the caller's argument is wrong; nothing was sent
    │   └── FieldError                      a field breaks the manual's limits (names the field)
    │       └── PacketTooLongError          the packet would exceed 250 bytes
    ├── ProtocolError                       the peer's bytes or behaviour break the protocol
    │   ├── FrameError                      the frame decoder was misused or fed a wrong type
    │   ├── LinkRuleError                   a link-layer rule was broken (names state and event)
    │   ├── MalformedAnswerError            an answer packet does not decode as its command's
    │   └── AnswerTooLongError              an answer ran past what its command can carry
    ├── ControllerError                     the controller answered with an error flag
    │   ├── RejectedError         (0x31)    the packet was not understood
    │   ├── FunctionFailedError   (0x32)    understood, but cannot be done now (KD reason)
    │   │   └── ControlHeldError              a line server's refusal: another holds control
    │   └── NotSupportedError     (0x33)    not supported by this controller
    ├── LineError                           the line failed
    │   ├── ReplyTimeoutError (TimeoutError)    no answer in time
    │   ├── OutcomeUnknownError             a state-changing command may or may not have run
    │   ├── NakLimitError                   the peer refused the same packet too many times
    │   ├── LinkResetError                  RST: the exchange was aborted
    │   ├── UploadIncompleteError           an FB upload did not finish (or could not be verified)
    │   └── PortError (OSError)             the port or socket could not be opened or used
    ├── WaitError                           waiting for the robot ended without success
    │   ├── WaitTimeoutError (TimeoutError)     the awaited condition did not come in time
    │   └── AlarmRaisedError                the channel raised an alarm while it was awaited
    └── JogInterruptedError                 a jog's keepalive failed; the robot has stopped

Where a controller error has a KD reason, it is in ``reason``.

Packages with errors of their own define them beside the code that raises them. Each is listed
here under the module to catch it from (``except robostar.serve.LineDownError``), with its bases;
tests/test_errors.py checks that this list names every exception class in robostar::

    robostar.serve                        the line server
      LineDownError (LineError)               the line is down or the server stops; nothing sent
      LineBusyError (LineError)               too many reads wait for the line; nothing sent
      AbortedByStopError (LineError)          a transfer was cancelled so that a stop goes out
      WithdrawnError (LineError)              its requester went away before it was sent
      ConfigError (UsageError)                the configuration is wrong (names the key)
      LeaseHeldError (RobostarError)          the caller does not hold the controller's lease
      LeaseLostError (LeaseHeldError)         the lease was lost while the change waited
      AuditError (RobostarError)              the audit log cannot be written: changes refused
    robostar.serve.faces.mqtt             the MQTT face (extra "mqtt")
      BusyError (RobostarError)               too many commands wait for a line on this face
    robostar.backup                       backup and restore
      BackupWriteError (RobostarError, OSError)   a backup could not be written on this computer
      RestoreIncompleteError (RobostarError)  a restore stopped part-way through its writes
      RestoreInterrupted (KeyboardInterrupt)  Ctrl-C during a restore's writes
    robostar.cli.profiles                 the console
      ProfileError (click.UsageError)         a profile file or a key in it is wrong
    robostar.sim.store                    the simulator's state folder
      StateFileError (UsageError)             a state file it cannot start from (names the key)

RestoreIncompleteError and RestoreInterrupted carry a RestoreState: what is written and
verified, in doubt and not touched.

Internal signals, caught inside the package that raises them (never seen by a caller)::

    robostar.controller_role.session
      Refusal (Exception)                     a backend will not carry a request out (flag, KD)
    robostar.sim.state
      Refused (Exception)                     the simulated controller will not carry it out
    robostar.sim.jobs
      JobSyntaxError (Exception)              a job's step does not parse
    robostar.sim.motion
      PathError (Exception)                   a simulated move cannot be made (names its alarm)
    robostar.sim.kinematics
      Unreachable (Exception)                 an XY point is outside the arm's reach
    robostar.sim.snapshot
      _Bad (Exception)                        a state file's value is wrong
    robostar.serve.http_guard
      BodyTooLarge (starlette.HTTPException)  an HTTP body grew past the limit (HTTP 413)
    robostar.serve.faces.web.deps
      Forbidden (Exception)                   a dashboard request is refused (HTTP status)
    robostar.serve.faces.mqtt.sparkplug.session
      NeedsBirth (Exception)                  a DDATA cannot carry a metric: birth the device
    robostar.serve.faces.modbus.runner
      _Refusal (RobostarError)                a Modbus write is refused (its reason register)
    robostar.cli.session
      DryRunDone (Exception)                  a dry run has printed its frames
    robostar.cli.keys
      TerminalLost (Exception)                the console's standard input closed
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: errors.py stays the root of the import graph
    from robostar.types import Alarm, ChannelStatus

__all__ = [
    "AlarmRaisedError",
    "AnswerTooLongError",
    "ControlHeldError",
    "ControllerError",
    "FieldError",
    "FrameError",
    "FunctionFailedError",
    "JogInterruptedError",
    "LineError",
    "LinkResetError",
    "LinkRuleError",
    "MalformedAnswerError",
    "NakLimitError",
    "NotSupportedError",
    "OutcomeUnknownError",
    "PacketTooLongError",
    "PortError",
    "ProtocolError",
    "RejectedError",
    "ReplyTimeoutError",
    "RobostarError",
    "UploadIncompleteError",
    "UsageError",
    "WaitError",
    "WaitTimeoutError",
    "error_for_flag",
]

# Flag bytes, repeated here (not imported) so that errors.py stays the root of the import graph.
_FLAG_REJECTED = 0x31
_FLAG_FAILED = 0x32
_FLAG_UNSUPPORTED = 0x33


class RobostarError(Exception):
    """Base of every error robostar raises."""


class UsageError(RobostarError, ValueError):
    """The caller passed something wrong. Nothing was sent to the controller."""


class FieldError(UsageError):
    """A field value breaks the manual's limits.

    ``command`` is the two-letter code (or ``""``), ``field`` the field's name. ``flag`` is the
    answer flag a controller gives for this fault when it meets it in a request (0x31 by default;
    the manual names 0x32 or 0x33 for some fields), so that the simulator answers as an N1 would.
    """

    def __init__(self, command: str, field: str, message: str, *, flag: int = _FLAG_REJECTED):
        self.command = command
        self.field = field
        self.message = message
        self.flag = flag
        where = f"{command} {field}" if command else field
        super().__init__(f"{where}: {message}")


class PacketTooLongError(FieldError):
    """The packet would be longer than the protocol's 250 bytes."""


class ProtocolError(RobostarError):
    """The peer broke the protocol."""


class FrameError(ProtocolError):
    """The frame decoder was given something it cannot take (not bytes)."""


class LinkRuleError(ProtocolError):
    """A link-layer rule was broken: ``event`` is not allowed in ``state``."""

    def __init__(self, role: str, state: str, event: str, detail: str = ""):
        self.role = role
        self.state = state
        self.event = event
        text = f"{role} link in state {state} cannot take {event}"
        super().__init__(f"{text}: {detail}" if detail else text)


class MalformedAnswerError(ProtocolError):
    """An answer from the controller does not decode as the command's answer."""

    def __init__(self, command: str, message: str, raw: bytes = b""):
        self.command = command
        self.raw = raw
        super().__init__(f"{command} answer: {message}" + (f" (raw {raw!r})" if raw else ""))


class AnswerTooLongError(ProtocolError):
    """A multi-packet answer went past what its command can carry (packets or bytes); the link
    ended it with RST and dropped what had come."""

    def __init__(self, command: str, detail: str = ""):
        self.command = command
        super().__init__(f"{command}: the answer is longer than the command can carry ({detail})")


class ControllerError(RobostarError):
    """The controller answered a command with an error flag."""

    flag: int = 0

    def __init__(self, command: str, reason: str | None = None):
        self.command = command
        self.reason = reason
        super().__init__(self._text())

    def _text(self) -> str:
        base = f"{self.command}: {self.describe}"
        return f"{base}: {self.reason}" if self.reason else base

    describe = "the controller answered with an error"


class RejectedError(ControllerError):
    """Flag 0x31: the controller did not understand the packet (bad field value or format)."""

    flag = _FLAG_REJECTED
    describe = "the controller rejected the packet (flag 0x31)"


class FunctionFailedError(ControllerError):
    """Flag 0x32: the command was understood but cannot be done now; ``reason`` is KD's text."""

    flag = _FLAG_FAILED
    describe = "the function failed (flag 0x32)"


_CONTROL_HELD = re.compile(
    r"line server: control of line (?P<line>\S+) is held by (?P<holder>.+) \((?P<face>[a-z0-9]+)\)"
    r" until (?P<until>[^;]+)"
)


class ControlHeldError(FunctionFailedError):
    """Flag 0x32 from a robostar line server, not from the controller: another consumer
    (``holder``, through ``face``) holds control of ``line`` (its lease) until ``until`` (a
    UTC wall clock); nothing was sent to the controller. Catch it to wait or to ask the holder;
    the controller's own last error (KD) knows nothing of it."""

    describe = "refused by the line server (flag 0x32)"

    def __init__(self, command: str, reason: str | None = None):
        found = _CONTROL_HELD.match(reason or "")
        self.line = found["line"] if found else ""
        self.holder = found["holder"] if found else ""
        self.face = found["face"] if found else ""
        self.until = found["until"] if found else ""
        super().__init__(command, reason)

    def _text(self) -> str:
        return (
            f"{self.command}: control of line {self.line} is held by {self.holder} ({self.face})"
            f" until {self.until}: the line server refused it; nothing was sent to the controller"
        )

    @staticmethod
    def text_for(line: str, holder: str, face: str, until: str) -> str:
        """The KD text of a robostar line server (its N1 face, ``serve://``) refusing a state
        change because ``holder`` (through ``face``) holds control of ``line`` until ``until``:
        what this error is read from. A controller never says "line server:"."""
        return (
            f"line server: control of line {line} is held by {holder} ({face}) until {until};"
            " nothing was sent"
        )

    @staticmethod
    def said_in(reason: str | None) -> bool:
        """Whether a KD text is a line server's "control is held" refusal."""
        return bool(reason) and _CONTROL_HELD.match(reason or "") is not None


class NotSupportedError(ControllerError):
    """Flag 0x33: the controller does not support this function."""

    flag = _FLAG_UNSUPPORTED
    describe = "not supported by this controller (flag 0x33)"


class LineError(RobostarError):
    """The line between host and controller failed."""


class ReplyTimeoutError(LineError, TimeoutError):
    """No answer came in time. Read-only commands may be retried safely."""

    def __init__(self, command: str, timeout: float, detail: str = ""):
        self.command = command
        self.timeout = timeout
        text = f"{command}: no answer within {timeout:g} s"
        super().__init__(f"{text} ({detail})" if detail else text)


class OutcomeUnknownError(LineError):
    """A state-changing command was sent but its answer was lost.

    The controller may or may not have carried it out. robostar never resends such a command on
    its own; check the controller's state (``status()``, ``position()``) before deciding.
    """

    def __init__(self, command: str, detail: str = ""):
        self.command = command
        text = (
            f"{command}: the outcome is unknown - the command may or may not have been carried "
            "out; check the controller's state before sending it again"
        )
        super().__init__(f"{text} ({detail})" if detail else text)


class NakLimitError(LineError):
    """The peer answered NAK to the same packet too many times."""

    def __init__(self, command: str, naks: int):
        self.command = command
        self.naks = naks
        super().__init__(f"{command}: the packet was refused (NAK) {naks} times; line is noisy")


class LinkResetError(LineError):
    """The exchange was aborted by RST (sent by the peer, or by us after a rule break)."""

    def __init__(self, command: str, detail: str = "RST received"):
        self.command = command
        super().__init__(f"{command}: exchange aborted: {detail}")


class UploadIncompleteError(LineError):
    """An FB upload did not complete, or its completion could not be confirmed."""


class PortError(LineError, OSError):
    """The port or socket could not be opened or used; the message says what to do."""


class WaitError(RobostarError):
    """Waiting for a channel ended without the awaited condition; ``status`` is the last read."""

    def __init__(self, message: str, channel: int, status: ChannelStatus | None) -> None:
        self.channel = channel
        self.status = status
        super().__init__(message)


class WaitTimeoutError(WaitError, TimeoutError):
    """The awaited condition did not come within the timeout."""


class AlarmRaisedError(WaitError):
    """The channel raised an alarm while it was awaited; ``alarms`` are the current alarms."""

    def __init__(
        self, message: str, channel: int, status: ChannelStatus, alarms: tuple[Alarm, ...]
    ) -> None:
        self.alarms = alarms
        super().__init__(message, channel, status)


class JogInterruptedError(RobostarError):
    """A jog ended early: its keepalive (BF) failed or the line was lost, so the controller
    stopped it (its watchdog stops a jog within 500 ms without keepalives). ``__cause__`` says
    why; ``stop_error`` is BG's outcome: None when BG went through, else why it did not."""

    def __init__(self, message: str, *, stop_error: BaseException | None = None) -> None:
        self.stop_error = stop_error
        super().__init__(message)


def error_for_flag(flag: int, command: str, reason: str | None = None) -> ControllerError:
    """The exception for an answer's error flag (0x31, 0x32 or 0x33)."""
    cls: type[ControllerError]
    if flag == _FLAG_REJECTED:
        cls = RejectedError
    elif flag == _FLAG_FAILED:
        cls = ControlHeldError if ControlHeldError.said_in(reason) else FunctionFailedError
    elif flag == _FLAG_UNSUPPORTED:
        cls = NotSupportedError
    else:
        raise ValueError(f"flag 0x{flag:02X} is not an error flag")
    return cls(command, reason)
