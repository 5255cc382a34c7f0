"""How an error reads on the console: a sentence, what to do next, and the exit code.

Exit codes (documented in docs/cli.md):

- 0: done;
- 2: a bad argument (nothing was sent);
- 3: the controller refused the command (the KD reason is shown when it gave one), or did not
  carry it out (an alarm, or the robot did not stop in time);
- 4: the line failed (no answer, RST, NAK storm, port trouble, an answer that breaks the protocol);
- 130: interrupted with Ctrl-C.
"""

from __future__ import annotations

from dataclasses import dataclass

from robostar.errors import (
    ControllerError,
    FieldError,
    FunctionFailedError,
    LineError,
    LinkResetError,
    NakLimitError,
    NotSupportedError,
    OutcomeUnknownError,
    PortError,
    ProtocolError,
    RejectedError,
    ReplyTimeoutError,
    RobostarError,
    UploadIncompleteError,
    UsageError,
)

__all__ = [
    "EXIT_BAD_ARGUMENT",
    "EXIT_INTERRUPTED",
    "EXIT_LINE",
    "EXIT_OK",
    "EXIT_REFUSED",
    "Failure",
    "explain",
]

EXIT_OK = 0
EXIT_BAD_ARGUMENT = 2
EXIT_REFUSED = 3
EXIT_LINE = 4
EXIT_INTERRUPTED = 130

_STATE_HINT = (
    "Check the channel with `robostar status` and `robostar alarms`: clear alarms with "
    "`robostar reset`, turn the servo on with `robostar servo on`, and home with `robostar home`."
)


@dataclass(frozen=True, slots=True)
class Failure:
    """An error as the console shows it."""

    exit_code: int
    message: str
    hint: str
    kind: str
    command: str | None = None
    reason: str | None = None

    def as_json(self) -> dict[str, object]:
        return {
            "error": {
                "type": self.kind,
                "exit_code": self.exit_code,
                "message": self.message,
                "hint": self.hint,
                "command": self.command,
                "reason": self.reason,
            }
        }


def _sentence(text: str) -> str:
    text = text.strip()
    if not text:
        return text
    first = text.split(" ", 1)[0]
    if first.rstrip(":,;").isalpha():
        # Only a word is capitalised: a message may start with a URL or a device path.
        text = text[0].upper() + text[1:]
    return text if text.endswith((".", "!", "?")) else text + "."


def explain(
    error: RobostarError, port: str, frames_sent: int = 0, changes_sent: int = 0
) -> Failure:
    """The console's reading of ``error``; ``port`` is the URL the command used,
    ``frames_sent`` how many frames the run had already written and ``changes_sent`` how many
    of its requests change the controller (so no message claims that nothing was sent when
    something was)."""
    kind = type(error).__name__
    if isinstance(error, UsageError):
        return _usage(error, kind, frames_sent, changes_sent)
    if isinstance(error, ControllerError):
        return _refusal(error, kind)
    if isinstance(error, LineError | ProtocolError):
        return _line(error, kind, port)
    return _client_logic(error, kind, port)


def _client_logic(error: RobostarError, kind: str, port: str) -> Failure:
    """Errors of the client's own logic: waiting for the robot, a jog's keepalive."""
    # Imported here: the console reads its first errors (bad arguments) without the client.
    from robostar.errors import AlarmRaisedError, JogInterruptedError, WaitTimeoutError

    message = _sentence(str(error))
    if isinstance(error, AlarmRaisedError):
        hint = "See `robostar alarms`; once the cause is fixed, clear it with `robostar reset`."
        reason = "; ".join(str(a) for a in error.alarms) or None
        return Failure(EXIT_REFUSED, message, hint, kind, reason=reason)
    if isinstance(error, WaitTimeoutError):
        hint = "Look with `robostar status`; give it longer with --wait-timeout."
        return Failure(EXIT_REFUSED, message, hint, kind)
    if isinstance(error, JogInterruptedError):
        cause = error.__cause__
        if isinstance(cause, RobostarError):
            inner = explain(cause, port)
            text = f"The jog stopped: {inner.message[0].lower()}{inner.message[1:]}"
            return Failure(inner.exit_code, text, inner.hint, kind, inner.command, inner.reason)
        return Failure(EXIT_LINE, message, "Run `robostar doctor` to check the line.", kind)
    return Failure(EXIT_REFUSED, message, _STATE_HINT, kind)


def _usage(error: UsageError, kind: str, frames_sent: int, changes_sent: int) -> Failure:
    if isinstance(error, FieldError):
        message = _sentence(f"The {error.field} is not valid: {error.message}")
    else:
        message = _sentence(str(error))
    if changes_sent:
        sent = (
            f"{changes_sent} command(s) that change the controller had already been sent "
            "before this check: see `robostar status`."
        )
    elif frames_sent:
        sent = "Only reads were sent before this check; nothing on the controller changed."
    else:
        sent = "Nothing was sent."
    return Failure(
        EXIT_BAD_ARGUMENT,
        message,
        f"{sent} Run the command with --help to see what it takes.",
        kind,
    )


def _refusal(error: ControllerError, kind: str) -> Failure:
    code, reason = error.command, error.reason
    if isinstance(error, FunctionFailedError):
        why = f": {reason}" if reason else " (it gave no reason)"
        message = f"The controller refused {code}{why}."
        hint = _STATE_HINT
    elif isinstance(error, RejectedError):
        message = f"The controller did not understand the {code} packet (flag 0x31)."
        if reason:
            message += f" Its reason: {reason}."
        hint = "Check the arguments; `robostar last-error` shows the controller's last reason."
    elif isinstance(error, NotSupportedError):
        message = f"This controller does not support {code} (flag 0x33)."
        hint = "Check its model and version with `robostar info`."
    else:
        message = _sentence(str(error))
        hint = _STATE_HINT
    return Failure(EXIT_REFUSED, message, hint, kind, code, reason)


def _line(error: RobostarError, kind: str, port: str) -> Failure:
    command = getattr(error, "command", None)
    if isinstance(error, ReplyTimeoutError):
        message = (
            f"No answer from the controller at {port} to {error.command} "
            f"within {error.timeout:g} s."
        )
        hint = (
            "Check that it is powered and connected and that the port and baud rate are right "
            "(`robostar doctor` checks them), or give it longer with --timeout."
        )
    elif isinstance(error, OutcomeUnknownError):
        message = _sentence(str(error))
        hint = "Look with `robostar status` and `robostar position` before you send it again."
    elif isinstance(error, NakLimitError):
        message = _sentence(str(error))
        hint = "The line is noisy: check the cable, its shielding and the baud rate."
    elif isinstance(error, LinkResetError):
        message = _sentence(str(error))
        hint = "Send the command again; if it keeps happening, run `robostar doctor`."
    elif isinstance(error, UploadIncompleteError):
        message = _sentence(str(error))
        hint = "Upload the file again and check it with `robostar files ls`."
    elif isinstance(error, PortError):
        message = _sentence(str(error))
        hint = (
            "Check --port (or ROBOSTAR_PORT): a serial device such as /dev/ttyUSB0, "
            "tcp://HOST:PORT, or sim:// for the built-in simulator."
        )
    elif isinstance(error, ProtocolError):
        message = _sentence(f"The controller's answer broke the protocol: {error}")
        hint = (
            "Capture the exchange with --trace FILE and read it with `robostar decode FILE`; "
            "`robostar doctor` checks the line."
        )
    else:
        message = _sentence(str(error))
        hint = "Run `robostar doctor` to check the line."
    return Failure(EXIT_LINE, message, hint, kind, command)
