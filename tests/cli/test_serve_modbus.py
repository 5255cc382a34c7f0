"""`robostar serve --modbus NAME=HOST:PORT` serves the line to a PLC and stops on SIGTERM."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
from pathlib import Path

from pymodbus.client import ModbusTcpClient

from robostar.serve.faces.modbus.layout import IR, MAP_VERSION


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_robostar_serve_starts_and_stops_the_modbus_face(tmp_path: Path) -> None:
    port = _free_port()
    command = [sys.executable, "-m", "robostar.cli", "serve", "--line", "cell1=sim://"]
    command += ["--modbus", f"cell1=127.0.0.1:{port}", "--audit", str(tmp_path / "audit.jsonl")]
    proc = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr is not None
        seen = []
        for line in proc.stderr:
            seen.append(line)
            if line.startswith("ready;"):
                break
        assert seen and seen[-1].startswith("ready;"), "".join(seen)
        assert any(line.startswith("serving modbus:") for line in seen), "".join(seen)
        plc = ModbusTcpClient("127.0.0.1", port=port, timeout=3)
        assert plc.connect()
        try:
            answer = plc.read_input_registers(0, count=IR.HEALTH)
            assert not answer.isError(), answer
            assert answer.registers[IR.MAP_VERSION] == MAP_VERSION
            assert answer.registers[IR.ONLINE] == 1
        finally:
            plc.close()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
