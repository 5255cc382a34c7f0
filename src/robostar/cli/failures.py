"""How an error reads on the console: a sentence, what to do next, and the exit code.

Exit codes (documented in docs/cli.md):

- 0: done;
- 2: a bad argument (nothing was sent), or a local file that cannot be written (a backup);
- 3: the controller refused the command (the KD reason is shown when it gave one), or did not
  carry it out (an alarm, or the robot did not stop in time);
- 4: the line failed (no answer, RST, NAK storm, port trouble, an answer that breaks the protocol);
- 130: interrupted with Ctrl-C.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from robostar.errors import (
    ControlHeldError,
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
from robostar.types import Alarm

if TYPE_CHECKING:  # the console explains its first errors without loading the client
    from robostar.backup.errors import RestoreState

__all__ = [
    "EXIT_BAD_ARGUMENT",
    "EXIT_INTERRUPTED",
    "EXIT_LINE",
    "EXIT_OK",
    "EXIT_REFUSED",
    "Failure",
    "explain",
    "next_step",
    "with_alarms_left",
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
    detail: str = ""
    """Protocol codes and the raw reason: shown below the sentence, never as the headline."""
    alarms: tuple[str, ...] = ()
    """Alarms a refused command left on the controller (Run Fail), read with AB after it."""
    restore: Mapping[str, object] | None = None
    """A restore that stopped part-way: what is written, in doubt and not touched."""

    def as_json(self) -> dict[str, object]:
        error: dict[str, object] = {
            "type": self.kind,
            "exit_code": self.exit_code,
            "message": self.message,
            "hint": self.hint,
            "command": self.command,
            "reason": self.reason,
            "detail": self.detail or None,
            "alarms_left": list(self.alarms),
        }
        if self.restore is not None:
            error["restore"] = dict(self.restore)
        return {"error": error}


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
    backup = sys.modules.get("robostar.backup.errors")  # loaded if the error can come from it
    if backup is not None and isinstance(error, backup.RestoreIncompleteError):
        return _half_restored(error, error.state, kind, port)
    if backup is not None and isinstance(error, backup.BackupWriteError):
        message = _sentence(str(error))
        hint = (
            "Only reads were sent; nothing on the controller changed. Free space on that disk or "
            "give a folder you can write to."
        )
        return Failure(EXIT_BAD_ARGUMENT, message, hint, kind)
    if isinstance(error, UsageError):
        return _usage(error, kind, frames_sent, changes_sent)
    if isinstance(error, ControllerError):
        return _refusal(error, kind)
    if isinstance(error, LineError | ProtocolError):
        return _line(error, kind, port)
    return _client_logic(error, kind, port)


def _half_restored(error: RobostarError, state: RestoreState, kind: str, port: str) -> Failure:
    """A restore that failed part-way: its state first, then what stopped it (with that
    error's exit code: 3 a refusal, 4 the line)."""
    cause = error.__cause__
    inner = explain(cause, port) if isinstance(cause, RobostarError) else None
    message = _sentence(state.describe())
    if inner is None:
        return Failure(EXIT_LINE, message, state.hint, kind, restore=state.as_json())
    # The line's own hint ("upload the file again") is what running the restore again does.
    own = inner.hint and not isinstance(cause, UploadIncompleteError)
    hint = (
        f"{state.hint} Before that: {inner.hint[0].lower()}{inner.hint[1:]}" if own else state.hint
    )
    return Failure(
        inner.exit_code,
        message,
        hint,
        kind,
        inner.command,
        inner.reason,
        inner.detail,
        restore=state.as_json(),
    )


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
            return Failure(
                inner.exit_code, text, inner.hint, kind, inner.command, inner.reason, inner.detail
            )
        return Failure(EXIT_LINE, message, "Run `robostar doctor` to check the line.", kind)
    return Failure(EXIT_REFUSED, message, _STATE_HINT, kind)


def _usage(error: UsageError, kind: str, frames_sent: int, changes_sent: int) -> Failure:
    if isinstance(error, FieldError):
        message = _sentence(f"The {error.field} is not valid: {error.message}")
    else:
        message = _sentence(str(error))
    own_hint = getattr(error, "hint", None)
    if isinstance(own_hint, str) and not changes_sent and not frames_sent:
        # An error that says what to do about itself (a state file, a simulator option):
        # not about a command's arguments, so neither "Nothing was sent" nor --help.
        return Failure(EXIT_BAD_ARGUMENT, message, own_hint, kind)
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


_ACTIONS = {
    "BA": "homing",
    "BB": "the move to a point",
    "BC": "the move",
    "BD": "the relative move",
    "BE": "the jog",
    "BF": "the jog",
    "BG": "stopping the jog",
    "CB": "setting the speed",
    "CC": "starting the job",
    "CD": "stopping the job",
    "CE": "resetting the job",
    "CF": "the emergency stop",
    "CG": "resetting the alarms",
    "CI": "stopping the homing",
    "CJ": "the restart",
    "CX": "setting the reference axis",
    "DB": "switching the servo",
    "DC": "selecting the job",
    "EA": "setting the job mode",
    "FA": "the download",
    "FB": "the upload",
    "FC": "looking up the file",
    "FD": "listing the files",
    "FE": "deleting the file",
    "FF": "copying the file",
    "FG": "renaming the file",
    "GC": "setting the output",
    "GR": "reading the global variable",
    "GW": "writing the global variable",
}

_CHANNEL = re.compile(r"channel (\d)")

# (words in the controller's reason, the next step); {c} is the channel option, "" for 1.
_NEXT_STEPS: tuple[tuple[tuple[str, ...], str], ...] = (
    (("servo is on",), "servo is on: `robostar servo off{c}` first"),
    (("servo is off", "servo must be on", "servo off"), "servo is off: `robostar servo on{c}`"),
    (
        ("origin return", "not homed", "homing is not done", "home first"),
        "the channel is not homed: `robostar home{c}`",
    ),
    (("has an alarm", "alarm came up"), "see `robostar alarms`, then clear with `robostar reset`"),
    (("no job selected",), "select a job: `robostar job select NAME{c}`"),
    (("running job", "busy", "run bit is on"), "stop it first: `robostar job stop{c}`"),
    (("speed is 0",), "set a speed: `robostar speed set 100{c}`"),
    (("no file", "already exists"), "see the files: `robostar files ls{c}`"),
    (("soft limit",), "the target is outside the soft limits: check it with `robostar position`"),
    (("no robot", "not configured"), "this channel has no robot: see `robostar info`"),
    (("no jog in progress",), "start the jog again: `robostar jog{c}`"),
)


RUN_FAIL = 9002


def with_alarms_left(failure: Failure, alarms: Sequence[Alarm]) -> Failure:
    """``failure`` saying which Run Fail alarm the refused command left, and how to clear it."""
    left = [a for a in alarms if a.code == RUN_FAIL or "run fail" in a.text.lower()]
    if not left:
        return failure
    names = ", ".join(str(a) for a in left)
    hint = (
        f"{failure.hint} The refusal left an alarm on the controller ({names}): "
        "clear it with `robostar reset` once the cause is fixed."
    )
    return replace(failure, hint=hint.strip(), alarms=tuple(str(a) for a in left))


def next_step(reason: str | None) -> str | None:
    """The specific next step for a controller's reason, when one is known."""
    if not reason:
        return None
    text = reason.lower()
    found = _CHANNEL.search(text)
    channel = f" -c {found.group(1)}" if found and found.group(1) != "1" else ""
    for words, step in _NEXT_STEPS:
        if any(w in text for w in words):
            return step.format(c=channel)
    return None


def _refusal(error: ControllerError, kind: str) -> Failure:
    code, reason = error.command, error.reason
    action = _ACTIONS.get(code, f"the {code} command")
    detail = f"Protocol: {code}, answer flag 0x{error.flag:02X}"
    if reason:
        detail += f"; KD reason: {reason}"
    if isinstance(error, ControlHeldError):
        # the line server's refusal, not the controller's: no controller recovery hints
        message = (
            f"Control of line {error.line} is held by {error.holder} ({error.face}) until"
            f" {error.until}: the line server refused {action}; nothing was sent."
        )
        hint = (
            f"Wait until it is given back, or ask {error.holder} to release control;"
            " this is the line server's refusal, the controller has no error."
        )
        return Failure(EXIT_REFUSED, message, hint, kind, code, reason, detail)
    action = action[0].upper() + action[1:]
    if isinstance(error, FunctionFailedError):
        why = f": {reason}" if reason else " (it gave no reason)"
        message = _sentence(f"{action} was refused by the controller{why}")
        step = next_step(reason)
        if step:
            hint = f"Next: {step}."
        elif code[:1] in "BCDE":
            hint = _STATE_HINT
        else:
            hint = "`robostar last-error` shows the controller's last reason in full."
    elif isinstance(error, RejectedError):
        message = f"{action} was not understood by the controller (a field it cannot take)."
        if reason:
            message += f" Its reason: {reason}."
        hint = "Check the arguments; `robostar last-error` shows the controller's last reason."
    elif isinstance(error, NotSupportedError):
        message = f"This controller does not support {action.lower()}."
        hint = "Check its model and version with `robostar info`."
    else:
        message = _sentence(str(error))
        hint = _STATE_HINT
    return Failure(EXIT_REFUSED, message, hint, kind, code, reason, detail)


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
