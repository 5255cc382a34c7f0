"""Ctrl-C exits 130 after stopping the motion the command started."""

from __future__ import annotations

import json
import signal
from collections.abc import Iterator
from typing import Any

import pytest

from robostar.client import Client


@pytest.fixture
def slow_line() -> Iterator[tuple[Any, str]]:
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.listeners import PeerHost

    controller = VirtualController(SimConfig(speedup=1))
    host = PeerHost(controller, name="interrupt-test")
    address = host.listen_tcp("127.0.0.1", 0)
    host.start()
    try:
        yield controller, f"tcp://{address[0]}:{address[1]}"
    finally:
        host.close()


def test_ctrl_c_stops_the_move_it_started(terminal: Any, slow_line: tuple[Any, str]) -> None:
    _controller, url = slow_line
    with Client(url) as client:
        client.servo(1, True)
        client.home(1, wait=True, timeout=60)
        client.set_speed(1, 20)
    term = terminal("--port", url, "move", "90", "90", "0", "0")
    term.wait_for("will move")  # the warning before the motion
    with Client(url) as client:
        for _ in range(200):
            if not client.status()[0].in_position:
                break
    # The terminal's job on Ctrl-C (the test's pty is not the process's controlling terminal).
    term.process.send_signal(signal.SIGINT)
    code = term.wait_exit()
    assert code == 130, term.text()
    said = " ".join(term.text().split())
    assert "Interrupted; stopped the move of channel 1 with an emergency stop (CF)" in said
    with Client(url) as client:
        assert client.status()[0].alarm  # the emergency stop's alarm, as the message says
        before = client.position(1, "angle").axes
        client.status()
        assert client.position(1, "angle").axes == before  # it no longer moves
        assert before[:2] != (90.0, 90.0)


# -- what Ctrl-C cut short ---------------------------------------------------------------------


def _interrupt_at(monkeypatch: pytest.MonkeyPatch, hit: Any) -> None:
    """Ctrl-C as the frame for which ``hit(record, count)`` holds goes out (the trace sees
    every frame just before the port does)."""
    from robostar.cli.session import ConsoleSession

    original = ConsoleSession._on_frame
    seen = {"n": 0}

    def on_frame(self: ConsoleSession, record: Any) -> None:
        original(self, record)
        if record.direction == "tx":
            seen["n"] += 1
            if hit(record, seen["n"]):
                raise KeyboardInterrupt

    monkeypatch.setattr(ConsoleSession, "_on_frame", on_frame)


def test_ctrl_c_during_an_upload_names_the_file_and_the_lines(
    run: Any, monkeypatch: pytest.MonkeyPatch, tmp_path: Any
) -> None:
    job = tmp_path / "BIG.JOB"
    job.write_text("MAIN\n" + "NOP\n" * 38 + "EOP\n")  # 40 lines
    uploads = {"n": 0}

    def sixteenth_line(record: Any, _count: int) -> bool:
        if record.kind == "upload line":
            uploads["n"] += 1
        return bool(uploads["n"] == 16)

    _interrupt_at(monkeypatch, sixteenth_line)
    result = run("files", "put", str(job))
    assert result.exit_code == 130
    said = " ".join(result.stderr.split())
    assert (
        "Interrupted: FB BIG.JOB aborted after 15/40 lines; "
        "the file on the controller may be missing or old." in said
    ), said
    uploads["n"] = 0
    as_json = run("--json", "files", "put", str(job))
    assert as_json.exit_code == 130
    error = json.loads(as_json.stderr)
    assert "aborted after 15/40 lines" in error["error"]["message"]
    assert error["simulator"] is True


def test_ctrl_c_during_a_state_change_says_its_outcome_is_unknown(
    run: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    _interrupt_at(
        monkeypatch, lambda record, _n: record.kind == "request" and record.command == "CB"
    )
    result = run("speed", "set", "300")
    assert result.exit_code == 130
    said = " ".join(result.stderr.split())
    assert "Interrupted: the outcome of CB is unknown; check it" in said, said


def test_ctrl_c_during_a_timed_jog_says_the_jog_was_stopped(
    run: Any, monkeypatch: pytest.MonkeyPatch, sim_line: Any
) -> None:
    import types

    import robostar.cli.jogpad as jogpad

    with Client(sim_line.url) as client:
        client.servo(1, True)

    def sleep(_seconds: float) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(jogpad, "time", types.SimpleNamespace(sleep=sleep))
    result = run("jog", "--direction", "+", "--for", "2", port=sim_line.url)
    assert result.exit_code == 130, result.output
    said = " ".join(result.stderr.split())
    assert "Interrupted; stopped the jog of channel 1 (BG sent)." in said, said
    with Client(sim_line.url) as client:
        assert not client.status()[0].running


def test_ctrl_c_during_a_backup_says_the_previous_one_is_intact(
    run: Any, monkeypatch: pytest.MonkeyPatch, tmp_path: Any
) -> None:
    _interrupt_at(monkeypatch, lambda record, _n: record.command == "FA")
    result = run("backup", str(tmp_path / "bk"))
    assert result.exit_code == 130
    said = " ".join(result.stderr.split())
    assert "the backup was not finished and nothing of it was kept" in said, said
    assert list(tmp_path.iterdir()) == [tmp_path / "bk"] or not list(tmp_path.iterdir())


@pytest.fixture
def paced_line() -> Iterator[str]:
    """A served simulator behind a 2400-baud line: an upload of 100 lines takes seconds."""
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.listeners import PeerHost, SimSessions

    controller = VirtualController(SimConfig(speedup=50))
    host = PeerHost(SimSessions(controller, baud=2400), name="paced-interrupt-test")
    address = host.listen_tcp("127.0.0.1", 0)
    host.start()
    try:
        yield f"tcp://{address[0]}:{address[1]}"
    finally:
        host.close()


def test_a_real_ctrl_c_during_an_upload(terminal: Any, paced_line: str, tmp_path: Any) -> None:
    job = tmp_path / "BIG.JOB"
    job.write_text("MAIN\n" + "MOVJ P1 V=50\n" * 98 + "EOP\n")  # 100 lines
    term = terminal("--port", paced_line, "files", "put", str(job))
    term.wait_for(lambda text: "uploading BIG.JOB" in text and "/100" in text, timeout=30)
    term.process.send_signal(signal.SIGINT)
    code = term.wait_exit()
    said = " ".join(term.text().split())
    assert code == 130, said
    assert "Interrupted: FB BIG.JOB aborted after " in said, said
    assert "/100 lines; the file on the controller may be missing or old." in said
