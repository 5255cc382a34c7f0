"""`watch` (the monitor) inside `robostar shell` runs on the shell's open connection.

It asked the session for its own client options (a 1 s timeout, reconnecting), which a session
refuses once its client is open, as the shell's always is: the RuntimeError ended the whole shell
with a traceback.
"""

from __future__ import annotations

import json

from .conftest import Run


def test_watch_in_the_shell_shows_a_refresh_and_the_shell_goes_on(run: Run) -> None:
    result = run("shell", input="watch --count 2 --rate 20\nstatus\n")
    assert result.exit_code == 0, result.output
    assert result.stdout.count("line OK") == 2
    assert "servo" in result.stdout.split("line OK")[-1]  # the next line ran too


def test_json_watch_in_the_shell(run: Run) -> None:
    result = run("shell", input="watch --json --count 1\n")
    assert result.exit_code == 0, result.output
    (line,) = [json.loads(x) for x in result.stdout.splitlines() if x.startswith("{")]
    assert line["line_ok"] is True
