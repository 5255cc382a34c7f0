"""The console calls an OSError a port error only when it is one: an error of a local file
(a filename, or a disk-full or permission errno) is a bad-argument exit, not "check the
cable"."""

from __future__ import annotations

import errno
from typing import Any

import pytest

from .conftest import Run


@pytest.mark.parametrize(
    ("error", "code", "words"),
    [
        (OSError(errno.ENOSPC, "No space left on device", "/data/x"), 2, "local file /data/x"),
        (OSError(errno.EACCES, "Permission denied"), 2, "local file"),
        (OSError(errno.EIO, "Input/output error"), 4, "The port failed"),
    ],
)
def test_only_port_errors_are_called_port_errors(
    run: Run, monkeypatch: pytest.MonkeyPatch, error: OSError, code: int, words: str
) -> None:
    from robostar.cli.session import ConsoleSession

    def send(self: ConsoleSession, command: Any) -> Any:
        raise error

    monkeypatch.setattr(ConsoleSession, "send", send)
    result = run("files", "rm", "OLD.JOB")
    assert result.exit_code == code
    assert words in result.stderr
    assert ("cable" in result.stderr) is (code == 4)
