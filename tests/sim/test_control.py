"""The control socket: inputs and alarms changed on a running simulator from outside."""

from __future__ import annotations

import threading

import pytest
from click.testing import CliRunner

from robostar import Client
from robostar.cli import cli
from robostar.sim import SimConfig
from robostar.sim.control import send_control
from robostar.sim.listeners import parse_listen, serve


@pytest.fixture
def running_sim():
    ready = threading.Event()
    endpoints: list[str] = []
    stop = threading.Event()

    def on_ready(found: list[str]) -> None:
        endpoints.extend(found)
        ready.set()

    thread = threading.Thread(
        target=serve,
        args=(SimConfig(),),
        kwargs=dict(
            listen="127.0.0.1:0", count=2, control="127.0.0.1:0", on_ready=on_ready, stop=stop
        ),
        daemon=True,
    )
    thread.start()
    assert ready.wait(10)
    yield endpoints
    stop.set()
    thread.join(10)


def _control(endpoints: list[str]) -> str:
    return next(e for e in endpoints if e.startswith("control://")).removeprefix("control://")


def test_serve_lists_a_control_endpoint(running_sim):
    assert sum(e.startswith("tcp://") for e in running_sim) == 2
    assert _control(running_sim).startswith("127.0.0.1:")


def test_sim_input_sets_an_input_the_client_reads(running_sim):
    tcp = [e for e in running_sim if e.startswith("tcp://")]
    result = CliRunner().invoke(
        cli, ["sim-input", "0", "3", "on", "--control", _control(running_sim), "--controller", "2"]
    )
    assert result.exit_code == 0, result.output
    with Client(tcp[1]) as second, Client(tcp[0]) as first:
        assert second.inputs(0)[3] is True
        assert first.inputs(0)[3] is False


def test_alarm_line_raises_an_alarm(running_sim):
    address = parse_listen(_control(running_sim))
    assert send_control(address, "alarm 1153 1") == "ok"
    tcp = next(e for e in running_sim if e.startswith("tcp://"))
    with Client(tcp) as robot:
        assert [a.code for a in robot.alarms()] == [1153]
        assert robot.status()[0].alarm


@pytest.mark.parametrize(
    ("line", "why"),
    [
        ("input 0 16 on", "contact 16"),
        ("input 0 3 maybe", "'maybe'"),
        ("input 0 3 on 3", "controller 3"),
        ("alarm 1153 5", "channel 5"),
        ("jump", "expected"),
    ],
)
def test_bad_lines_are_refused_with_a_reason(running_sim, line, why):
    answer = send_control(parse_listen(_control(running_sim)), line)
    assert answer.startswith("error:") and why in answer


def test_sim_input_without_a_simulator_says_how_to_start_one():
    result = CliRunner().invoke(cli, ["sim-input", "0", "3", "on", "--control", "127.0.0.1:9"])
    assert result.exit_code == 2
    assert "robostar sim --control" in result.output
