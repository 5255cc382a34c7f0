"""The simulator's journal: every state change it carried out, with its time, session and
outcome, and the motion it started, so that the state at any instant can be known from it
(``SimConfig(journal=...)``, ``VirtualController(journal=...)``, ``robostar sim --journal``)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

import robostar
from robostar.errors import FunctionFailedError
from robostar.sim import SimConfig
from robostar.sim.controller import VirtualController
from robostar.sim.journal import Journal, file_digest, path_at, read_journal
from robostar.sim.listeners import SimServer


def _replay(entries: list[dict[str, Any]], until: float) -> dict[str, Any]:
    """The journaled state at real time ``until``."""
    state: dict[str, Any] = {}
    for entry in entries:
        if entry["t"] > until:
            break
        if entry["ev"] == "start":
            state = dict(entry["state"])
        else:
            state.update(entry["set"])
    return state


def _commands(entries: list[dict[str, Any]], code: str) -> list[dict[str, Any]]:
    return [e for e in entries if e["ev"] == "cmd" and e["code"] == code]


def test_commands_are_journaled_with_their_session_outcome_and_changes() -> None:
    journal = Journal(keep=True)
    controller = VirtualController(SimConfig(), journal=journal)
    with SimServer(controller) as server, robostar.Client(server.url) as client:
        client.write_global_int(7, 4242)
        client.set_output(0, 3, True)
        client.status()  # a read: not journaled
        with pytest.raises(FunctionFailedError):
            client.move(1, (500.0, 0.0, 0.0, 0.0), coords="angle")  # no origin: refused + alarm
    entries = journal.entries
    assert entries is not None
    assert entries[0]["ev"] == "start"
    assert [e["code"] for e in entries if e["ev"] == "cmd"] == ["GW", "GC", "BC"]
    (write,) = _commands(entries, "GW")
    assert write["cmd"] == {"index": 7, "value": 4242}
    assert write["result"] == "done"
    assert write["set"] == {"int.7": 4242}
    assert write["session"] == _commands(entries, "GC")[0]["session"]
    assert _commands(entries, "GC")[0]["set"] == {"out": [8, 0, 0, 0, 0]}
    (refused,) = _commands(entries, "BC")
    assert refused["result"] == "refused"
    assert "origin" in refused["reason"]
    assert refused["set"]["alarms"] and refused["set"]["status"][0] & 0x08


def test_a_motion_is_journaled_so_that_every_read_position_lies_on_its_path() -> None:
    journal = Journal(keep=True)
    controller = VirtualController(SimConfig(), journal=journal)
    reads: list[tuple[float, float, tuple[float, ...]]] = []
    with SimServer(controller) as server, robostar.Client(server.url) as client:
        client.servo(1, True)
        client.home(1, wait=True)
        client.move_by(1, (30.0, -20.0, 0.0, 0.0), coords="angle")
        while True:
            before = time.monotonic()
            position = client.position(1, "angle")
            reads.append((before, time.monotonic(), position.axes))
            if not client.status()[0].running:
                break
    entries = journal.entries
    assert entries is not None
    (move,) = _commands(entries, "BD")
    path = move["set"]["ch1.path"]
    assert path["start"] == [0.0, 0.0, 0.0, 0.0]
    assert path["end"] == [30.0, -20.0, 0.0, 0.0]
    assert path["duration"] > 0
    assert len(reads) > 2  # some reads met the arm on its way
    for before, after, axes in reads:
        # The value read is the path's at some instant between asking and the answer.
        low, high = path_at(path, before), path_at(path, after)
        for axis, value in enumerate(axes):
            lo, hi = sorted((low[axis], high[axis]))
            assert lo - 0.002 <= value <= hi + 0.002
    ended = _replay(entries, time.monotonic())
    assert ended["ch1.path"] is None
    assert ended["ch1.joints"] == pytest.approx([30.0, -20.0, 0.0, 0.0])


def test_an_uploaded_file_is_journaled_by_the_digest_a_download_gives(tmp_path: Path) -> None:
    target = tmp_path / "run.jsonl"
    controller = VirtualController(SimConfig(journal=str(target)))
    lines = ("MAIN", "DELAY 10", "EOP")
    with SimServer(controller) as server, robostar.Client(server.url) as client:
        client.upload_job(1, "T1.JOB", list(lines))
        downloaded = client.download_job(1, "T1.JOB")
        client.delete_file(1, "T1.JOB")
    assert controller.journal is not None
    controller.journal.close()
    entries = list(read_journal(target))
    (upload,) = _commands(entries, "FB")
    assert upload["set"]["file.1.T1.JOB"] == file_digest(lines=downloaded.lines)
    (delete,) = _commands(entries, "FE")
    assert delete["set"] == {"file.1.T1.JOB": None}


def test_robostar_sim_writes_the_journal_it_is_given(tmp_path: Path) -> None:
    target = tmp_path / "sim.jsonl"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from robostar.cli import cli; cli()",
            "sim",
            "--listen",
            "127.0.0.1:0",
            "--journal",
            str(target),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        url = proc.stdout.readline().strip()
        assert url.startswith("tcp://"), url
        with robostar.Client(url) as client:
            client.set_speed(1, 250)
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=10)
    (speed,) = _commands(list(read_journal(target)), "CB")
    assert speed["cmd"] == {"channel": 1, "speed": 250}
    assert speed["set"] == {"ch1.speed": 250}
