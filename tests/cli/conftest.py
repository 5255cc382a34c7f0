"""Helpers for the command-line tests: run `robostar` in-process against the simulator."""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from click.testing import CliRunner, Result

from robostar.cli import cli

SIM = "sim://?speedup=50"
"""The in-process simulator, fast enough that no test waits long for a motion."""

Run = Callable[..., Result]
"""The ``run`` and ``on`` fixtures: ``robostar ARGS`` in-process, click's Result back."""
AsJson = Callable[[Result], Any]
"""The ``as_json`` fixture."""


@pytest.fixture
def run() -> Run:
    """Invoke ``robostar ARGS`` and return click's Result (exit code, stdout, stderr)."""
    runner = CliRunner()

    def invoke(*args: str, input: str | bytes | None = None, port: str | None = SIM) -> Result:
        argv = (["--port", port] if port else []) + list(args)
        return runner.invoke(cli, argv, input=input, catch_exceptions=False)

    return invoke


def _as_json(result: Result) -> Any:
    assert result.exit_code == 0, result.output
    try:
        return json.loads(result.stdout)
    except json.JSONDecodeError:
        pytest.fail(f"not JSON: {result.stdout!r}")


@pytest.fixture
def as_json() -> Callable[[Result], Any]:
    """The JSON document a --json run printed (the run must have succeeded)."""
    return _as_json


class SimLine:
    """A simulator served on 127.0.0.1 for the length of a test, so state carries between runs."""

    def __init__(self, host: Any, controller: Any, url: str):
        self.host = host
        self.controller = controller
        self.url = url

    def set_input(self, port: int, contact: int, on: bool) -> None:
        with self.host.lock:
            self.controller.model.set_input(port, contact, on)

    def jobs(self, channel: int = 1) -> dict[str, list[str]]:
        """The channel's files as the simulator holds them: name -> lines (none for a PNT)."""
        with self.host.lock:
            files = self.controller.model.channel(channel).files
            return {str(f.name): list(getattr(f, "lines", [])) for f in files}


@pytest.fixture
def sim_line() -> Iterator[SimLine]:
    from robostar.sim import SimConfig, VirtualController
    from robostar.sim.listeners import PeerHost

    controller = VirtualController(SimConfig(speedup=50))
    host = PeerHost(controller, name="cli-test")
    address = host.listen_tcp("127.0.0.1", 0)
    host.start()
    try:
        yield SimLine(host, controller, f"tcp://{address[0]}:{address[1]}")
    finally:
        host.close()


@pytest.fixture
def on(run: Run, sim_line: SimLine) -> Run:
    """`run` against the served simulator, whose state carries from one command to the next."""

    def invoke(*args: str, **kwargs: Any) -> Result:
        return run(*args, port=sim_line.url, **kwargs)

    return invoke


class Terminal:
    """The real `robostar` process in a pseudo-terminal; the screen is read back with pyte."""

    def __init__(self, args: list[str], *, columns: int = 110, rows: int = 32):
        import fcntl
        import os
        import pty
        import struct
        import subprocess
        import sys
        import termios

        import pyte

        self.screen = pyte.Screen(columns, rows)
        self.stream = pyte.ByteStream(self.screen)
        self.master, slave = pty.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", rows, columns, 0, 0))
        env = dict(os.environ, COLUMNS=str(columns), LINES=str(rows), TERM="xterm-256color")
        env.pop("ROBOSTAR_PORT", None)
        self.process = subprocess.Popen(
            [sys.executable, "-m", "robostar.cli", *args],
            stdin=slave,
            stdout=slave,
            stderr=slave,
            env=env,
            start_new_session=True,
            close_fds=True,
        )
        os.close(slave)
        self.raw = bytearray()

    def pump(self, wait: float = 0.05) -> None:
        """Read whatever the process wrote within ``wait`` seconds into the screen."""
        import os
        import select

        end = time.monotonic() + wait
        while True:
            left = end - time.monotonic()
            ready, _, _ = select.select([self.master], [], [], max(left, 0))
            if not ready:
                return
            try:
                data = os.read(self.master, 65536)
            except OSError:
                return
            if not data:
                return
            self.raw += data
            self.stream.feed(data)

    def text(self) -> str:
        return "\n".join(self.screen.display)

    def line_with(self, needle: str) -> str:
        for line in self.screen.display:
            if needle in line:
                return line
        return ""

    def wait_for(self, needle: str | Callable[[str], bool], timeout: float = 15.0) -> str:
        """Pump until the screen shows ``needle`` (or the predicate holds); fail otherwise."""
        check = needle if callable(needle) else (lambda text: needle in text)
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.pump(0.05)
            if check(self.text()):
                return self.text()
            if self.process.poll() is not None:
                self.pump(0.2)
                if check(self.text()):
                    return self.text()
                break
        pytest.fail(
            f"screen never showed {needle!r}:\n{self.text()}\nraw tail: {bytes(self.raw[-600:])!r}"
        )

    def send(self, keys: str | bytes) -> None:
        import os

        os.write(self.master, keys.encode() if isinstance(keys, str) else keys)

    def hold(self, keys: str, seconds: float, every: float = 0.04) -> None:
        """Send ``keys`` again and again, as a held key's autorepeat does."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.send(keys)
            self.pump(every)

    def wait_exit(self, timeout: float = 15.0) -> int:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.pump(0.05)
            code = self.process.poll()
            if code is not None:
                self.pump(0.1)
                return code
        pytest.fail(f"the process did not exit:\n{self.text()}")

    def close(self) -> None:
        import os

        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(5)
            except Exception:
                self.process.kill()
                self.process.wait(5)
        with contextlib.suppress(OSError):
            os.close(self.master)


@pytest.fixture
def terminal() -> Iterator[Callable[..., Terminal]]:
    """Start `robostar ARGS` in a pseudo-terminal; every one started is closed afterwards."""
    started: list[Terminal] = []

    def start(*args: str, columns: int = 110, rows: int = 32) -> Terminal:
        term = Terminal(list(args), columns=columns, rows=rows)
        started.append(term)
        return term

    yield start
    for term in started:
        term.close()


class RealControllerStandIn:
    """A byte peer that answers as a real N1 does: the simulator behind it, with its AD version
    as a real controller's firmware writes it (no -SIM mark), and any name it is given.

    No simulator setting can drop the mark, so this is how the console tests meet a controller
    whose identity is not a simulator's (an N1 host program sees nothing else of it).
    """

    def __init__(self, *, name: str = "LINE3", version: str = "N1RO 03.02.05") -> None:
        from robostar.protocol.frame import FrameDecoder
        from robostar.sim import SimConfig, VirtualController

        self.controller = VirtualController(SimConfig(speedup=50))
        self.name = name
        self.version = version
        self._requests = FrameDecoder()
        self._answers = FrameDecoder()
        self._last_request = b""

    def feed(self, data: bytes, now: float) -> None:
        from robostar.protocol.frame import Packet

        for event in self._requests.feed(data):
            if isinstance(event, Packet):
                self._last_request = event.data
        self.controller.feed(data, now)

    def output(self, now: float) -> bytes:
        from robostar.protocol.frame import Control, Packet, encode_packet

        out = bytearray()
        for event in self._answers.feed(self.controller.output(now)):
            if isinstance(event, Packet):
                out += encode_packet(self._as_real(event.data))
            elif isinstance(event, Control):
                out.append(event.kind.value)
        return bytes(out)

    def next_deadline(self) -> float | None:
        return self.controller.next_deadline()

    def _as_real(self, data: bytes) -> bytes:
        from dataclasses import replace

        from robostar.commands.status import ReadInfo

        if self._last_request != b"\xffAD" or data[1:2] != b"0":
            return data
        command = ReadInfo()
        info = command.decode_answer([data])
        (answer,) = command.encode_answer(replace(info, name=self.name, version=self.version))
        return answer


@pytest.fixture
def served() -> Iterator[Callable[..., str]]:
    """Serve a byte peer (a VirtualController, a stand-in) for the test and return its --port
    URL: TCP on 127.0.0.1, or with ``pty=True`` a pseudo-terminal's device."""
    from robostar.sim.listeners import PtyServer, SimServer

    servers: list[Any] = []

    def serve(peer: Any, *, pty: bool = False) -> str:
        if pty:
            tty = PtyServer(peer, name="cli-test").start()
            servers.append(tty)
            return tty.device_path
        tcp = SimServer(peer, name="cli-test").start()
        servers.append(tcp)
        return tcp.url

    yield serve
    for server in servers:
        server.close()
