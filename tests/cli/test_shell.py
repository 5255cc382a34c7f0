"""`robostar shell`: one connection for many commands, completion, history, status line."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from click.testing import Result

from robostar.cli.session import ConsoleSession, Settings
from robostar.cli.shell import ShellState, candidates, split_line

Run = Callable[..., Result]


def test_piped_lines_share_one_connection(run: Run) -> None:
    # The in-process simulator lives as long as its connection: servo on in one line is still
    # on in the next only if both ran on the same one.
    lines = "servo on\n--json status\n# a comment\n\nexit\nstatus\n"
    result = run("shell", input=lines)
    assert result.exit_code == 0, result.output
    status = json.loads(next(line for line in result.stdout.splitlines() if line.startswith("{")))
    assert status["channels"][0]["servo_on"] is True and status["simulator"] is True
    assert result.stdout.count("Status") == 0  # exit stopped the last line


def test_a_bad_line_does_not_end_the_shell(run: Run) -> None:
    result = run("shell", input="bogus\nservo on -c 9\nio in 0\n")
    assert "No such command 'bogus'" in result.output
    assert "9 is not in the range" in result.output
    assert "in 0" in result.stdout  # the line after the errors ran
    assert result.exit_code == 2  # piped: the worst exit code, for scripts


def test_lines_cannot_change_the_target(run: Run) -> None:
    result = run("shell", input="--port tcp://127.0.0.1:1 status\n--trace x.jsonl status\n")
    assert "leave it (exit) to change --port" in result.output
    assert "give it to `robostar shell` itself" in result.output


def test_shell_needs_a_target(run: Run) -> None:
    result = run("shell", input="status\n", port=None)
    assert result.exit_code == 2 and "--port" in result.output


def test_split_line_aliases_and_quotes() -> None:
    assert split_line("watch --rate 2") == ["monitor", "--rate", "2"]
    assert split_line("files rm 'X.JOB'  # gone") == ["files", "rm", "X.JOB"]
    with pytest.raises(Exception, match="cannot read the line"):
        split_line("files rm 'X.JOB")


def test_completion_candidates() -> None:
    session = ConsoleSession(Settings("sim://", None, False, None, 1, False))
    state = ShellState(session)
    try:
        assert "status" in candidates(state, [], "st")
        assert "watch" in candidates(state, [], "")
        assert set(candidates(state, ["files"], "")) >= {"ls", "get", "rm"}
        assert list(candidates(state, ["servo", "on", "-c"], "")) == ["1", "2", "3"]
        assert "DEMO.PNT" in candidates(state, ["move-point"], "DE")
        assert list(candidates(state, ["move-point", "DEMO.PNT"], "")) == ["1", "2", "3"]
        assert "SIMULATOR" in state.status_line() and "servo off" in state.status_line()
    finally:
        session.close()


def test_interactive_shell(
    terminal: Any, sim_line: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    history = tmp_path / "history"
    monkeypatch.setenv("ROBOSTAR_HISTORY", str(history))
    term = terminal("--port", "sim://", "shell")
    answered = 0

    def answer_cursor_request() -> None:
        # pyte does not answer prompt_toolkit's cursor position request (sent before each
        # prompt): answer it as a terminal would, or the status line is never drawn.
        nonlocal answered
        term.wait_for(lambda _text: term.raw.count(b"\x1b[6n") > answered)
        answered = term.raw.count(b"\x1b[6n")
        term.send("\x1b[1;1R")

    answer_cursor_request()
    term.wait_for("robostar [SIMULATOR] ch1>")
    term.wait_for(lambda text: "SIMULATOR sim://" in text and "servo off" in text)
    term.send("serv\t")
    term.wait_for("ch1> servo")
    term.send(" on\r")
    term.wait_for("servo is on")
    answer_cursor_request()
    term.wait_for("servo ON")  # the status line follows
    term.send("move-point DEMO.P\t")
    term.wait_for("move-point DEMO.PNT")
    term.send("\x15")  # Ctrl-U: drop the line
    term.send("jog\r")  # the jog pad without leaving the shell
    term.wait_for("robostar jog")
    term.send("q")
    term.wait_for("Jog pad closed")
    answer_cursor_request()
    term.wait_for("robostar [SIMULATOR] ch1>")
    term.send("exit\r")  # read by the shell after the pad: it never left
    assert term.wait_exit() == 0
    assert "servo on" in history.read_text()


def test_the_shell_neither_offers_nor_runs_the_line_server() -> None:
    from robostar.cli.shell import _commands

    assert "serve" not in _commands() and "shell" not in _commands()
    assert "servo" in _commands()
