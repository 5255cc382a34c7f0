"""Bad input to every CLI command: exit status 2, the argument named, nothing on the wire.

Each case runs ``robostar --trace FILE ARGS`` on the built-in simulator with one argument out of
range, of the wrong type or malformed. The trace must hold no frame sent by the host.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from robostar.cli import cli

SIM = "sim://?speedup=50"

# (argv, the argument the message must name: any of the |-separated spellings, any case; the
# CLI names an argument as a person reads it, "New name 'x.y'", "Url 'nosuch://x'")
CASES: list[tuple[list[str], str]] = [
    (["--channel", "4", "status"], "channel"),
    (["--channel", "x", "status"], "channel"),
    (["--timeout", "0", "status"], "timeout"),
    (["--timeout", "soon", "status"], "timeout"),
    (["--port", "nosuch://x", "status"], "url|port"),
    (["position", "--kind", "polar"], "kind"),
    (["position", "-c", "0"], "channel"),
    (["params", "--index", "100"], "index"),
    (["params", "--index", "-2"], "index"),
    (["servo", "maybe"], "on|off"),
    (["servo", "on", "-c", "9"], "channel"),
    (["home", "--wait-timeout", "0"], "wait-timeout"),
    (["move", "a", "b"], "coordinates"),
    (["move", "1", "2", "3", "4", "5", "6", "7"], "coordinates"),
    (["move", "nan", "1"], "coordinates"),
    (["move", "1e12", "1"], "coordinates"),
    (["move", "--via", "1,x", "--arc", "1", "2"], "via"),
    (["move", "--arc", "1", "2"], "via"),
    (["move", "--by", "--arc", "--via", "1,2", "1", "2"], "arc"),
    (["move-point", "DEMO.PNT", "-1"], "point"),
    (["move-point", "DEMO.PNT", "10000"], "point"),
    (["move-point", "DEMO.PNT", "x"], "point"),
    (["move-point", "TOOLONG.PNT", "1"], "file"),
    (["move-point", "DEMO.JOB", "1"], "file"),
    (["move-point", "DEMO.PNT", "1", "--via", "-5"], "via"),
    (["speed", "set", "1001"], "value"),
    (["speed", "set", "-1"], "value"),
    (["speed", "set", "fast"], "value"),
    (["job", "mode", "fast"], "auto|step"),
    (["job", "select", "TOOLONG.JOB"], "name"),
    (["job", "select", "Mixed.JOB"], "name"),
    (["job", "select", "DEMO.PNT"], "name|file"),
    (["job", "start", "-c", "0"], "channel"),
    (["io", "in", "5"], "port"),
    (["io", "in", "x"], "port"),
    (["io", "out", "-1"], "port"),
    (["io", "set", "0", "16", "on"], "contact"),
    (["io", "set", "5", "1", "on"], "port"),
    (["io", "set", "0", "1", "maybe"], "on|off"),
    (["global", "get", "int", "500"], "index"),
    (["global", "get", "float", "-1"], "index"),
    (["global", "get", "point", "1024"], "index"),
    (["global", "get", "bool", "1"], "int|float|point"),
    (["global", "get", "point", "5", "--axis", "7"], "axis"),
    (["global", "set", "int", "600", "5"], "index"),
    (["global", "set", "int", "5", "x"], "value"),
    (["global", "set", "int", "5", "1.5"], "value"),
    (["global", "set", "int", "5", "10000000"], "value"),
    (["global", "set", "float", "5", "nan"], "value"),
    (["global", "set", "float", "5", "1e9"], "value"),
    (["global", "set", "point", "5", "1", "x"], "value|point"),
    (["global", "set", "point", "5", "1", "2", "3", "4", "5", "6", "7"], "value"),
    (["global", "set", "point", "5", "1", "--arm", "up"], "arm"),
    (["ref-axis", "2"], "1|4"),
    (["files", "ls", "A B"], "pattern"),
    (["files", "ls", "A*/B"], "pattern"),
    (["files", "get", "TOOLONG.JOB"], "name"),
    (["files", "get", "DEMO.TXT"], "name"),
    (["files", "rm", "Bad.JOB"], "name"),
    (["files", "cp", "DEMO.JOB", "TOOLONG.JOB"], "new_name|new name"),
    (["files", "mv", "DEMO.JOB", "x.y"], "new_name|new name"),
    (["files", "put", "no-such-file.JOB"], "source"),
    (["jog", "--axis", "7"], "axis"),
    (["jog", "--for", "61", "--direction", "+"], "for"),
    (["jog", "--direction", "up", "--for", "1"], "direction"),
    (["jog", "--speed", "2000"], "speed"),
    (["monitor", "--rate", "0"], "rate"),
    (["monitor", "--count", "0"], "count"),
    (["monitor", "--ports", "9", "--count", "1"], "ports"),
    (["monitor", "--channels", "1,7", "--count", "1"], "channels"),
    (["raw", "A"], "code|command"),
    (["raw", "A!"], "code|command"),
    (["raw", "AA", "--shape", "weird"], "shape"),
    (["doctor", "--count", "0"], "count"),
    (["backup"], "folder"),
    (["restore", "no-such-folder"], "folder"),
    (["sim", "--count", "0"], "count"),
    (["sim", "--listen", "nowhere"], "listen"),
    (["sim", "--fault", "explode:1"], "fault"),
    (["sim", "--baud", "5"], "baud"),
    (["decode", "--format", "xml"], "format"),
    (["decode", "--hex", "zz"], "hex"),
    # #11: NaN, the infinities and timeouts the clock cannot wait for, refused before the wire
    (["--timeout", "nan", "status"], "timeout"),
    (["--timeout", "inf", "status"], "timeout"),
    (["--timeout", "1e10", "status"], "timeout"),
    (["home", "--wait-timeout", "nan"], "wait-timeout"),
    (["home", "--wait-timeout", "inf"], "wait-timeout"),
    (["home", "--wait-timeout", "1e10"], "wait-timeout"),
    (["move", "1", "2", "--wait-timeout", "nan"], "wait-timeout"),
    (["move", "1", "2", "--wait-timeout", "-inf"], "wait-timeout"),
    (["move-point", "DEMO.PNT", "1", "--wait-timeout", "nan"], "wait-timeout"),
    (["jog", "--for", "nan", "--direction", "+"], "for"),
    (["jog", "--for", "inf", "--direction", "+"], "for"),
    (["monitor", "--rate", "nan", "--count", "1"], "rate"),
    (["monitor", "--rate", "inf", "--count", "1"], "rate"),
    # #11: names the controller cannot hold are refused, never silently changed
    (["files", "rm", "A B.JOB"], "name"),
    (["files", "rm", "AB\x00.JOB"], "name"),
    (["files", "get", " AB.JOB"], "name"),
    (["files", "cp", "DEMO.JOB", "A B.JOB"], "new_name|new name"),
    (["files", "mv", "DEMO.JOB", "AB\x00.JOB"], "new_name|new name"),
    (["files", "put", "--name", "A B.JOB", "pyproject.toml"], "name"),
    (["job", "select", "A B.JOB"], "name"),
    (["move-point", "D MO.PNT", "1"], "file"),
    # #12: --arm with joint angles would be ignored by the controller: refused
    (["global", "set", "point", "5", "10", "20", "0", "0", "--arm", "left"], "arm"),
]


def _id(case: tuple[list[str], str]) -> str:
    return " ".join(case[0])


@pytest.mark.parametrize("case", CASES, ids=_id)
def test_bad_cli_argument_exits_2_and_sends_nothing(
    case: tuple[list[str], str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    argv, name = case
    if "pyproject.toml" in argv:
        (tmp_path / "pyproject.toml").write_text("X\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("ROBOSTAR_PORT", raising=False)
    trace = tmp_path / "trace.jsonl"
    port = [] if "--port" in argv else ["--port", SIM]
    result = CliRunner().invoke(cli, [*port, "--trace", str(trace), *argv])
    text = (result.output + getattr(result, "stderr", "")).lower()
    assert result.exit_code == 2, f"exit {result.exit_code}: {result.output}"
    names = name.split("|")
    assert any(n in text for n in names), f"the message does not name {name!r}: {result.output}"
    sent = []
    if trace.exists():
        records = [json.loads(line) for line in trace.read_text().splitlines() if line.strip()]
        sent = [r for r in records if r.get("direction") == "tx"]
    assert sent == [], f"frames were sent: {sent}"


def test_every_cli_command_is_covered() -> None:
    covered = {argv[0] if not argv[0].startswith("-") else argv[2] for argv, _ in CASES}
    no_arguments = {"status", "info", "alarms", "last-error", "estop", "reset", "restart"}
    assert set(cli.commands) - covered - no_arguments - {"demo"} == set()


def test_the_trace_shows_what_a_good_command_sends(tmp_path: Path) -> None:
    # The control for the check above: a valid command does leave its frames in the trace.
    trace = tmp_path / "trace.jsonl"
    result = CliRunner().invoke(cli, ["--port", SIM, "--trace", str(trace), "speed", "set", "500"])
    assert result.exit_code == 0, result.output
    records = [json.loads(line) for line in trace.read_text().splitlines() if line.strip()]
    assert [r["kind"] for r in records if r["direction"] == "tx"][:1] == ["request"]


# -- the library: floats and names checked before the first byte ----------------------------


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf"), 1e10, 0.0, -1.0])
def test_library_timeouts_refuse_non_finite_and_huge(value: float) -> None:
    from robostar.client import Client
    from robostar.errors import UsageError

    with pytest.raises(UsageError, match="timeout"):
        Client(SIM, timeout=value)
    sent: list[object] = []
    with Client(SIM, trace=lambda r: sent.append(r) if r.direction == "tx" else None) as client:
        with pytest.raises(UsageError, match="timeout"):
            client.home(1, wait=True, timeout=value)
        with pytest.raises(UsageError, match="timeout"):
            client.move(1, (1.0, 2.0, 0.0, 0.0), wait=True, timeout=value)
        with pytest.raises(UsageError, match="timeout"):
            client.wait_stopped(1, value)
    assert sent == []


@pytest.mark.parametrize("name", ["A B.JOB", "AB\x00.JOB", " AB.JOB", "AB.JOB\n", "A/B.JOB"])
def test_library_refuses_names_the_wire_would_change(name: str) -> None:
    from robostar.client import Client
    from robostar.errors import UsageError

    sent: list[object] = []
    with Client(SIM, trace=lambda r: sent.append(r) if r.direction == "tx" else None) as client:
        for call in (
            lambda: client.delete_file(1, name),
            lambda: client.download_job(1, name),
            lambda: client.file_exists(1, name),
            lambda: client.rename_file(1, "DEMO.JOB", name),
            lambda: client.upload_job(1, name, ["MAIN", "EOP"]),
        ):
            with pytest.raises(UsageError, match="no spaces, no control characters"):
                call()
    assert sent == []
