"""Raw key reading from a terminal (termios + select), for the jog pad and the monitor.

Terminals report key presses, never releases: a held key arrives as one press, then (after the
keyboard's autorepeat delay) a stream of repeats. The jog pad turns that into "held" and
"released" by timing; this module only yields key names as they arrive.
"""

from __future__ import annotations

import os
import select
import sys
import termios
import tty
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

__all__ = ["KeyReader", "TerminalLost", "parse_keys"]

_SEQUENCES = {
    "\x1b[A": "up",
    "\x1b[B": "down",
    "\x1b[C": "right",
    "\x1b[D": "left",
    "\x1bOA": "up",
    "\x1bOB": "down",
    "\x1bOC": "right",
    "\x1bOD": "left",
}
_SINGLE = {
    "\x1b": "esc",
    "\t": "tab",
    "\r": "enter",
    "\n": "enter",
    "\x03": "ctrl-c",
    " ": "space",
    "\x7f": "backspace",
    "\x08": "backspace",
}


class TerminalLost(Exception):
    """Standard input closed or failed: the console can no longer be heard."""


def parse_keys(text: str) -> list[str]:
    """Key names in ``text``: arrows as ``up``/``down``/``left``/``right``, others as typed."""
    keys = []
    i = 0
    while i < len(text):
        for seq, name in _SEQUENCES.items():
            if text.startswith(seq, i):
                keys.append(name)
                i += len(seq)
                break
        else:
            if text.startswith("\x1b[", i):
                # An escape sequence this pad does not use (F-keys, Home...): skip it whole.
                j = i + 2
                while j < len(text) and not (0x40 <= ord(text[j]) <= 0x7E):
                    j += 1
                i = j + 1
                continue
            char = text[i]
            keys.append(_SINGLE.get(char, char))
            i += 1
    return keys


class KeyReader:
    """Reads keys from a terminal put in cbreak mode (no echo, no line buffering)."""

    def __init__(self, stream: TextIO | None = None):
        self._stream = stream or sys.stdin

    @property
    def _fd(self) -> int:
        return self._stream.fileno()

    def is_terminal(self) -> bool:
        try:
            return self._stream.isatty() and os.isatty(self._fd)
        except (OSError, ValueError):
            return False

    @contextmanager
    def cbreak(self) -> Iterator[KeyReader]:
        """Hold the terminal in cbreak mode; restore it however the block ends."""
        saved = termios.tcgetattr(self._fd)
        try:
            tty.setcbreak(self._fd)
            yield self
        finally:
            termios.tcsetattr(self._fd, termios.TCSADRAIN, saved)

    def read(self, timeout: float) -> list[str]:
        """The keys that arrive within ``timeout`` seconds (empty when none did)."""
        try:
            ready, _, _ = select.select([self._fd], [], [], max(timeout, 0.0))
            if not ready:
                return []
            data = os.read(self._fd, 1024)
        except OSError as error:
            raise TerminalLost(str(error)) from error
        if not data:
            raise TerminalLost("standard input closed")
        return parse_keys(data.decode("utf-8", "replace"))
