"""``robostar trace check``: the frames of a field trace that robostar's reading refuses."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from click.testing import Result

from robostar import Client
from robostar.client.trace import WireTrace
from robostar.commands.job import Servo
from robostar.commands.variables import ReadGlobalFloat
from robostar.protocol.frame import ACK, encode_packet
from robostar.protocol.packets import make_answer
from robostar.sim import SimConfig, VirtualController
from robostar.transport import PeerTransport

Run = Callable[..., Result]
AsJson = Callable[[Result], Any]


def _recorded(path: Path, dialect: str = "manual") -> None:
    sim = VirtualController(SimConfig(dialect=dialect, seed=1))
    with Client(PeerTransport(sim), trace=path) as client:
        client.status()
        client.write_global_float(2, 123456.123)
        client.read_global_float(2)
        client.upload_job(1, "TC.JOB", ("MAIN", "EOP"))
        client.download_job(1, "TC.JOB")


def _exchange(trace: WireTrace, request: bytes, *answers: bytes) -> None:
    trace.sent(encode_packet(request))
    for answer in answers:
        trace.received(encode_packet(answer))
        trace.sent(bytes((ACK,)))


def test_a_trace_robostar_reads_whole_passes(run: Run, as_json: AsJson, tmp_path: Path) -> None:
    for dialect in ("manual", "capacity", "left-aligned", "padded"):
        path = tmp_path / f"{dialect}.trace"
        _recorded(path, dialect)
        result = run("trace", "check", str(path), port=None)
        assert result.exit_code == 0, result.output
        assert "reads every one" in result.output
        data = as_json(run("--json", "trace", "check", str(path), port=None))
        assert data["problems"] == [] and data["frames"] > 10


def test_refused_frames_are_named_with_their_rule_and_bytes(
    run: Run, as_json: AsJson, tmp_path: Path
) -> None:
    path = tmp_path / "field.trace"
    _recorded(path)
    trace = WireTrace(path)
    _exchange(trace, Servo(1, True).encode(), make_answer(0x30, b"99999999"), make_answer(0x30))
    _exchange(trace, ReadGlobalFloat(3).encode(), make_answer(0x30, b"12.3456"))
    trace.received(b"\x02\x30\x41\x03\x00")  # a bad LRC
    trace.close()
    result = run("--json", "trace", "check", str(path), port=None)
    assert result.exit_code == 1
    problems = json.loads(result.output)["problems"]
    rules = [(p["command"], p["rule"]) for p in problems]
    assert any(code == "DB" and "two digits" in rule for code, rule in rules)
    assert any(code == "GR" and "does not decode" in rule for code, rule in rules)
    assert any("bad LRC" in p["rule"] for p in problems)
    assert all(p["bytes"] for p in problems)
    human = run("trace", "check", str(path), port=None)
    assert human.exit_code == 1
    assert "refused" in human.output


def test_a_missing_trace_is_a_usage_error(run: Run, tmp_path: Path) -> None:
    result = run("trace", "check", str(tmp_path / "none.trace"), port=None)
    assert result.exit_code == 2
    assert "cannot read" in result.output.lower()
