"""Replay: a recording of a session answers a live host as the controller did (issue #19)."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from robostar import Client
from robostar.errors import ReplyTimeoutError, UsageError
from robostar.sim import SimConfig, VirtualController
from robostar.sim.replay import ReplayController, load_trace, serve_replay
from robostar.transport import PeerTransport
from robostar.types import Point

JOB = ("MAIN", "MOVE P1", "EOP")


def _session(client: Client) -> list[object]:
    """The same calls, live and replayed."""
    client.upload_job(1, "RP.JOB", JOB)
    client.write_global_float(4, 123456.123)
    client.write_global_point(1, 9, Point((1.0, 2.0, 3.0, 4.0)))
    return [
        client.status(),
        client.position(1, "angle"),
        client.read_global_float(4),
        client.read_global_point(1, 9),
        client.download_job(1, "RP.JOB"),
        client.list_files(1),
        client.info(),
        client.alarms(),
    ]


def _record(path: Path, dialect: str = "manual") -> list[object]:
    sim = VirtualController(SimConfig(seed=3, dialect=dialect))
    with Client(PeerTransport(sim), trace=path, timeout=1.0) as client:
        return _session(client)


@pytest.mark.parametrize("dialect", ["manual", "capacity", "padded"])
def test_a_recorded_session_replays_with_the_same_results(tmp_path: Path, dialect: str) -> None:
    trace = tmp_path / "field.trace"
    live = _record(trace, dialect)
    replay = ReplayController(trace)
    with Client(PeerTransport(replay), timeout=0.5) as client:
        assert _session(client) == live
    assert replay.divergences == []
    assert replay.finished


def test_a_host_that_asks_something_else_is_reported_and_gets_no_answer(tmp_path: Path) -> None:
    trace = tmp_path / "field.trace"
    _record(trace)
    replay = ReplayController(trace)
    with Client(PeerTransport(replay), timeout=0.2, retries=0) as client:
        client.upload_job(1, "RP.JOB", JOB)
        with pytest.raises(ReplyTimeoutError):
            client.read_global_int(77)  # never recorded
    assert len(replay.divergences) == 1
    assert "the recording has" in str(replay.divergences[0])


def test_a_file_that_is_not_a_trace_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "bad.trace"
    bad.write_text("not json\n")
    with pytest.raises(UsageError, match="line 1: not a trace record"):
        load_trace(bad)
    with pytest.raises(UsageError, match="No such file"):
        load_trace(tmp_path / "missing.trace")


def test_serve_replay_answers_over_tcp(tmp_path: Path) -> None:
    trace = tmp_path / "field.trace"
    live = _record(trace)
    ready: list[str] = []
    stop = threading.Event()
    result: list[ReplayController] = []

    def run() -> None:
        result.append(serve_replay(trace, listen="127.0.0.1:0", on_ready=ready.extend, stop=stop))

    thread = threading.Thread(target=run)
    thread.start()
    try:
        for _ in range(200):
            if ready:
                break
            threading.Event().wait(0.01)
        with Client(ready[0], timeout=0.5) as client:
            assert _session(client) == live
    finally:
        stop.set()
        thread.join(10)
    assert result and result[0].divergences == []
