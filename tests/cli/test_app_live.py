"""`jog` and `monitor` as a technician uses them: the real process in a pseudo-terminal."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path

from robostar.client import Client

RIGHT = "\x1b[C"
UP = "\x1b[A"
FAST_SIM = "sim://?speedup=20"


def requests(trace: Path) -> list[str]:
    """The command codes the host sent, in order, from a --trace file."""
    codes = []
    for line in trace.read_text().splitlines():
        record = json.loads(line)
        if record.get("direction") == "tx" and record.get("kind") == "request":
            codes.append(record["command"])
    return codes


def axis_value(line: str) -> float:
    match = re.search(r"axis \d\s+(-?\d+\.\d+)", line)
    assert match, line
    return float(match.group(1))


def test_jog_pad_moves_only_while_the_key_is_held(
    terminal: Callable[..., object], tmp_path: Path
) -> None:
    trace = tmp_path / "jog.jsonl"
    term = terminal("--port", FAST_SIM, "--trace", str(trace), "jog", "--speed", "50")
    term.wait_for("robostar jog")
    term.wait_for(lambda text: "axis 1" in text and "0.000" in text)
    start = axis_value(term.line_with("axis 1"))

    term.hold(RIGHT, 0.7)
    assert "jogging +" in term.raw.decode("utf-8", "replace"), term.text()
    # Released: the repeats stop, so the pad stops the jog on its own.
    term.wait_for("stopped", timeout=3)
    term.pump(0.5)
    moved = axis_value(term.line_with("axis 1"))
    assert moved > start
    term.pump(0.5)
    assert axis_value(term.line_with("axis 1")) == moved, "the robot kept moving after release"

    term.send("2")
    term.send(UP)
    term.wait_for("speed 100")
    term.wait_for(lambda text: "▶  axis 2" in text)

    term.send("q")
    assert term.wait_exit() == 0
    assert "Jog pad closed; jog stopped." in term.text()

    sent = requests(trace)
    assert "BE" in sent and "BF" in sent
    first_jog = sent.index("BE")
    assert "BG" in sent[first_jog:]
    assert "CB" in sent  # the speed change
    last_keepalive = len(sent) - 1 - sent[::-1].index("BF")
    assert "BG" in sent[last_keepalive:]


def test_jog_pad_stops_when_the_terminal_goes_away(
    terminal: Callable[..., object], tmp_path: Path
) -> None:
    import os

    trace = tmp_path / "lost.jsonl"
    term = terminal("--port", FAST_SIM, "--trace", str(trace), "jog", "--speed", "20")
    term.wait_for("robostar jog")
    term.hold(RIGHT, 0.3)
    assert "jogging +" in term.raw.decode("utf-8", "replace"), term.text()
    # The technician's terminal closes with the key still down.
    os.close(term.master)
    term.master = os.open(os.devnull, os.O_RDONLY)
    term.process.wait(15)
    sent = requests(trace)
    assert "BE" in sent
    assert "BG" in sent[sent.index("BE") :]


def test_monitor_shows_every_channel_and_a_dead_line(terminal, sim_line) -> None:
    term = terminal("--port", sim_line.url, "monitor", "--rate", "5", "--ports", "0")
    term.wait_for("line OK")
    term.wait_for("RSA60A")
    text = term.wait_for("alarms: none")
    assert "XY" in text  # channel 2's model

    with Client(sim_line.url) as client:
        client.emergency_stop()
    term.wait_for("Host Emergency")

    sim_line.set_input(0, 3, True)
    term.wait_for(lambda text: "●" in _lamps_row(text, "in 0"))
    row = _lamps_row(term.text(), "in 0")
    assert row.split()[2:6] == ["○", "○", "○", "●"], row

    sim_line.host.close()
    term.wait_for("NO ANSWER", timeout=15)

    term.send("q")
    assert term.wait_exit() == 0


def _lamps_row(text: str, label: str) -> str:
    for line in text.splitlines():
        if label in line and ("○" in line or "●" in line):
            return line.strip("│ ")
    return ""
