"""``robostar serve``: config checks, bad input, and a real process serving N1 and metrics."""

from __future__ import annotations

import asyncio
import signal
import socket
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from click.testing import CliRunner

from robostar import Client
from robostar.cli.app import cli
from robostar.errors import UsageError
from robostar.serve import ConfigError, load_config

GOOD = """
audit_path = "audit.jsonl"
[lines.cell1]
url = "sim://"
poll_interval = 0.1
channels = { 1 = "scara", 2 = "gantry" }
[lines.cell2]
url = "tcp://127.0.0.1:20000"
[n1.lines]
cell1 = "127.0.0.1:9301"
"""


def test_check_accepts_a_good_config(tmp_path: Path) -> None:
    path = tmp_path / "serve.toml"
    path.write_text(GOOD)
    result = CliRunner().invoke(cli, ["serve", "--check", str(path)])
    assert result.exit_code == 0, result.output
    assert "OK (2 lines)" in result.output
    config = load_config(path)
    assert config.lines[0].channels == {1: "scara", 2: "gantry"}
    assert config.faces["n1"] == {"lines": {"cell1": "127.0.0.1:9301"}}


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ('[lines.cell1]\nurl = "sim://"\npoll_interval = -1\n', "lines.cell1.poll_interval"),
        ('[lines.cell1]\nurl = "sim://"\npoll_interval = "fast"\n', "lines.cell1.poll_interval"),
        ("[lines.cell1]\nbaudrate = 9600\n", "lines.cell1.url"),
        ('[lines.cell1]\nurl = "sim://"\ncolour = 1\n', "lines.cell1.colour"),
        ('[lines.cell1]\nurl = "sim://"\nio_ports = [7]\n', "lines.cell1.io_ports"),
        ('[lines.cell1]\nurl = "sim://"\nchannels = { 5 = "x" }\n', "lines.cell1.channels"),
        ('[lines."1bad"]\nurl = "sim://"\n', "lines.'1bad'"),
        ('[lines.cell1]\nurl = "tcp://127.0.0.1:99999"\n', "lines.cell1.url"),
        ('[lines.cell1]\nurl = "tcp://[::1:5000"\n', "lines.cell1.url"),
        ('[lines.cell1]\nurl = "bogus://x"\n', "lines.cell1.url"),
        ("[nonsense]\nx = 1\n", "nonsense"),
        ("lines = 3\n", "lines"),
        ("[lines.cell1\n", "not valid TOML"),
    ],
)
def test_a_bad_config_names_the_key(tmp_path: Path, text: str, key: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as caught:
        load_config(path)
    assert key in str(caught.value)
    result = CliRunner().invoke(cli, ["serve", "--check", str(path)])
    assert result.exit_code != 0
    assert key.lower() in result.output.lower()


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ('[lines.cell1]\nurl = "sim://"\n[mqtt]\nurl = "mqtt://h"\nqos = 5\n', "mqtt.qos"),
        ('[lines.cell1]\nurl = "sim://"\n[mqtt]\nurl = "ftp://h"\n', "mqtt.url"),
        ('[lines.cell1]\nurl = "sim://"\n[n1.lines]\ncell9 = "127.0.0.1:0"\n', "n1.lines.cell9"),
        ('[lines.cell1]\nurl = "sim://"\n[opcua]\nlisten = "127.0.0.1:4840"\n', "opcua.users"),
        (
            '[lines.cell1]\nurl = "sim://"\n[opcua]\nusers = "u.toml"\nglobals = { x = [1] }\n',
            "opcua.globals",
        ),
    ],
)
def test_check_also_checks_each_faces_options(tmp_path: Path, text: str, key: str) -> None:
    path = tmp_path / "faces.toml"
    path.write_text(text)
    result = CliRunner().invoke(cli, ["serve", "--check", str(path)])
    assert result.exit_code != 0
    assert key in result.output


def test_bad_command_line_is_refused_before_anything_opens() -> None:
    runner = CliRunner()
    result = runner.invoke(cli, ["serve", "--line", "nourl"])
    assert result.exit_code != 0 and "NAME=URL" in result.output
    result = runner.invoke(cli, ["serve"])
    assert result.exit_code != 0 and "--line" in result.output
    result = runner.invoke(cli, ["serve", "--line", "a=sim://", "--allow-remote"])
    assert result.exit_code != 0 and "--token" in result.output
    result = runner.invoke(cli, ["serve", "--line", "a=sim://", "--opcua-allow-anonymous-read"])
    assert result.exit_code != 0 and "needs --opcua" in result.output


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_a_served_line_works_for_a_client_and_stops_on_sigterm(tmp_path: Path) -> None:
    n1, metrics = _free_port(), _free_port()
    audit = tmp_path / "audit.jsonl"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "robostar.cli",
            "serve",
            "--line",
            "cell1=sim://",
            "--n1",
            f"cell1=127.0.0.1:{n1}",
            "--metrics",
            f"127.0.0.1:{metrics}",
            "--audit",
            str(audit),
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stderr is not None
        seen = []
        for line in proc.stderr:
            seen.append(line)
            if line.startswith("ready;"):
                break
        assert seen and seen[-1].startswith("ready;"), "".join(seen)
        with Client(f"tcp://127.0.0.1:{n1}") as client:
            client.set_speed(1, 55)
            assert client.speed(1) == 55
        with urllib.request.urlopen(f"http://127.0.0.1:{metrics}/metrics", timeout=5) as reply:
            text = reply.read().decode()
        assert 'robostar_line_up{line="cell1"} 1.0' in text
        assert "robostar_line_exchanges_total" in text
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert '"SetSpeed' in audit.read_text() or "SetSpeed" in audit.read_text()


def test_metrics_with_a_token_want_it_and_remote_metrics_need_one() -> None:
    from tests.serve.conftest import sim_server

    from robostar.serve.faces import metrics as metrics_face

    with pytest.raises(UsageError, match="needs a token"):
        metrics_face.create(sim_server(), {"listen": "0.0.0.0:0", "allow_remote": True})

    async def main() -> None:
        async with sim_server() as server:
            face = metrics_face.create(server, {"listen": "127.0.0.1:0", "token": "s3cret"})
            await face.start()
            try:
                assert face.address is not None
                url = f"http://127.0.0.1:{face.address[1]}/metrics"

                def get(headers: dict[str, str]) -> tuple[int, str]:
                    request = urllib.request.Request(url, headers=headers)
                    try:
                        with urllib.request.urlopen(request, timeout=5) as reply:
                            return reply.status, reply.read().decode()
                    except urllib.error.HTTPError as error:
                        return error.code, ""

                assert (await asyncio.to_thread(get, {}))[0] == 401
                assert (await asyncio.to_thread(get, {"Authorization": "Bearer nope"}))[0] == 401
                status, text = await asyncio.to_thread(get, {"Authorization": "Bearer s3cret"})
                assert status == 200 and "robostar_line_up" in text
            finally:
                await face.stop()

    asyncio.run(main())
