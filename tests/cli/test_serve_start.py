"""What `robostar serve` starts with: an audit log unless told not to (everything that moves a
robot or writes to it is recorded by default, in the user's state folder; turning it off is
said), and a summary that never shows a secret."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from robostar.cli.serve import _describe, build_config
from robostar.errors import UsageError
from robostar.serve.config import ConfigError, config_from_mapping, default_audit_path

NO_FACES: dict[str, str | None] = {}


def _config(*, audit: str | None = None, no_audit: bool = False, file: str | None = None):
    return build_config(file, ("cell1=sim://",), (), NO_FACES, False, None, audit, no_audit)


def test_without_a_path_the_audit_goes_to_the_users_state_folder() -> None:
    config = _config()
    assert config.audit_path == str(default_audit_path())
    # the suite's own state folder (tests/conftest.py), never the home of whoever runs it
    assert config.audit_path.startswith(os.environ["XDG_STATE_HOME"])
    assert f"audit log: {config.audit_path}" in _describe(config)


def test_a_path_given_wins(tmp_path: Path) -> None:
    assert _config(audit=str(tmp_path / "a.jsonl")).audit_path == str(tmp_path / "a.jsonl")
    file = tmp_path / "serve.toml"
    file.write_text(f'audit_path = "{tmp_path / "b.jsonl"}"\n')
    assert _config(file=str(file)).audit_path == str(tmp_path / "b.jsonl")


def test_turned_off_only_when_asked_and_then_said(tmp_path: Path) -> None:
    config = _config(no_audit=True)
    assert config.audit_path is None and not config.audit
    assert any("audit log: OFF" in text for text in _describe(config))
    file = tmp_path / "serve.toml"
    file.write_text("audit = false\n")
    assert _config(file=str(file)).audit_path is None


def test_contradictions_are_refused(tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="choose one"):
        _config(audit=str(tmp_path / "a.jsonl"), no_audit=True)
    with pytest.raises(ConfigError, match="choose one"):
        config_from_mapping({"audit": False, "audit_path": "x.jsonl"})
    with pytest.raises(ConfigError, match="not true or false"):
        config_from_mapping({"audit": "no"})


def test_robostar_serve_without_audit_options_records_a_write_in_the_default_file() -> None:
    import signal
    import socket
    import subprocess
    import sys

    from robostar import Client

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        n1 = int(s.getsockname()[1])
    path = default_audit_path()
    assert not path.exists() or "SetSpeed" not in path.read_text()
    command = [sys.executable, "-m", "robostar.cli", "serve", "--line", "cell1=sim://"]
    proc = subprocess.Popen(
        [*command, "--n1", f"cell1=127.0.0.1:{n1}"], stderr=subprocess.PIPE, text=True
    )
    try:
        assert proc.stderr is not None
        seen = []
        for line in proc.stderr:
            seen.append(line)
            if line.startswith("ready;"):
                break
        assert f"audit log: {path}\n" in seen, "".join(seen)
        with Client(f"tcp://127.0.0.1:{n1}") as client:
            client.set_speed(1, 44)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert "SetSpeed(channel=1, speed=4.4 %)" in path.read_text()  # 44 ‰, said in %


def test_the_start_summary_never_shows_a_password_of_the_mqtt_url() -> None:
    from robostar.cli.serve import without_password

    faces = {"mqtt": "mqtt://cell3:S3cret-pw@127.0.0.1:1883?ca=/etc/ca.pem"}
    config = build_config(None, ("cell1=sim://",), (), faces, False, None, None, True)
    text = "\n".join(_describe(config))
    assert "S3cret-pw" not in text and "mqtt://cell3:***@127.0.0.1:1883?ca=/etc/ca.pem" in text
    assert without_password("mqtt://127.0.0.1:1883") == "mqtt://127.0.0.1:1883"
    assert without_password("mqtt://ann@[::1]:1883") == "mqtt://ann@[::1]:1883"
    assert without_password("mqtts://ann:p@ss@host:8883") == "mqtts://ann:***@host:8883"


def test_audit_file_on_the_command_line_wins_over_the_files_audit_false(tmp_path: Path) -> None:
    file = tmp_path / "serve.toml"
    file.write_text("audit = false\n")
    config = _config(audit=str(tmp_path / "a.jsonl"), file=str(file))
    assert config.audit_path == str(tmp_path / "a.jsonl") and config.audit


def test_a_password_holding_url_characters_is_hidden_too() -> None:
    from robostar.cli.serve import without_password

    assert without_password("mqtt://user:se/cret@broker:1883") == "mqtt://user:***@broker:1883"
    assert without_password("mqtt://user:a?b#c@broker") == "mqtt://user:***@broker"
    assert (
        without_password("mqtts://broker:8883?ca=/etc/ca.pem")
        == "mqtts://broker:8883?ca=/etc/ca.pem"
    )


def test_the_start_says_where_each_face_serves_never_none() -> None:
    from types import SimpleNamespace

    from robostar.cli.serve import serving

    mqtt = SimpleNamespace(settings=object())  # connects out: no address of its own
    url = {"url": "mqtt://cell3:S3cret-pw@127.0.0.1:1883"}
    assert serving("mqtt", mqtt, url) == "serving mqtt: mqtt://cell3:***@127.0.0.1:1883"
    n1 = SimpleNamespace(addresses={"cell1": ("127.0.0.1", 9101), "cell2": ("::1", 9102)})
    assert serving("n1", n1, {}) == "serving n1: cell1 on 127.0.0.1:9101, cell2 on [::1]:9102"
    api = SimpleNamespace(address=("127.0.0.1", 8470))
    assert serving("api", api, {"listen": "127.0.0.1:0"}) == "serving api: 127.0.0.1:8470"
    assert "None" not in serving("opcua", SimpleNamespace(), {})
