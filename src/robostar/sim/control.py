"""The simulator's control socket: change the outside world of a running simulator.

A loopback TCP socket taking one command per line, so that a test script or
``robostar sim-input`` can flip a sensor input or raise an alarm while clients talk to the
controllers over their own endpoints::

    input PORT CONTACT on|off [CTRL]     set an input contact (CTRL: controller 1..N, default 1)
    alarm CODE [CHANNEL] [CTRL]          raise an alarm (CHANNEL 1-3, default all)

Each line is answered ``ok`` or ``error: <why>``. Every change is made holding the controller
host's lock, as the hosts' own threads do. Only what the simulator defines is taken (the alarm
codes of its table, existing ports, contacts, channels and controllers), so a command can never
leave the state unreadable. A line longer than :data:`MAX_LINE` bytes and connections past
:data:`MAX_CONNECTIONS` are refused with ``error: ...`` and the connection closed.
"""

from __future__ import annotations

import contextlib
import socket
import socketserver
import threading
from collections.abc import Sequence
from typing import Any

from robostar.errors import UsageError
from robostar.sim.alarms import ALL_CHANNELS, AlarmCode
from robostar.sim.host import PeerHost

__all__ = ["MAX_CONNECTIONS", "MAX_LINE", "ControlServer", "send_control"]

MAX_LINE = 256
"""Longest command line taken, in bytes (the longest valid one is a few dozen)."""
MAX_CONNECTIONS = 8
"""Control connections served at once (one thread each)."""
_ALARM_CODES = ", ".join(str(int(code)) for code in AlarmCode)


def _controller_of(host: PeerHost) -> Any:
    """The VirtualController inside a host's peer (under any fault or pacing wrappers)."""
    peer: Any = host.peer
    if hasattr(peer, "controller"):
        return peer.controller
    while not hasattr(peer, "model"):
        peer = peer.peer
    return peer


def _number(what: str, word: str) -> int:
    if not word.isascii() or not word.isdigit() or len(word) > 6:
        raise UsageError(f"{what} {word!r} is not a whole number")
    return int(word)


def _switch(word: str) -> bool:
    value = word.lower()
    if value in ("on", "1", "true"):
        return True
    if value in ("off", "0", "false"):
        return False
    raise UsageError(f"{word!r} is not on or off")


class ControlServer:
    """Serves the control commands for ``hosts`` on a loopback address (port 0 = any free)."""

    def __init__(self, hosts: Sequence[PeerHost], host: str = "127.0.0.1", port: int = 0):
        if host not in ("127.0.0.1", "localhost", "::1"):
            raise UsageError(f"control: {host} is not a loopback address")
        self.hosts = list(hosts)
        owner = self

        class _Handler(socketserver.StreamRequestHandler):
            def handle(self) -> None:
                while True:
                    raw = self.rfile.readline(MAX_LINE + 1)
                    if not raw:
                        return
                    if len(raw) > MAX_LINE and not raw.endswith(b"\n"):
                        self.wfile.write(f"error: line longer than {MAX_LINE} bytes\n".encode())
                        return
                    line = raw.decode("utf-8", "replace").strip()
                    if line:
                        self.wfile.write((owner.execute(line) + "\n").encode())

        class _Server(socketserver.ThreadingTCPServer):
            daemon_threads = True
            allow_reuse_address = True
            block_on_close = False

            def __init__(self, *args: Any) -> None:
                super().__init__(*args)
                self.active = 0
                self.count_lock = threading.Lock()

            def process_request(self, request: Any, client_address: Any) -> None:
                with self.count_lock:
                    full = self.active >= MAX_CONNECTIONS
                    if not full:
                        self.active += 1
                if full:
                    with contextlib.suppress(OSError):
                        request.sendall(
                            f"error: already {MAX_CONNECTIONS} control connections\n".encode()
                        )
                    self.shutdown_request(request)
                    return
                super().process_request(request, client_address)

            def process_request_thread(self, request: Any, client_address: Any) -> None:
                try:
                    super().process_request_thread(request, client_address)
                finally:
                    with self.count_lock:
                        self.active -= 1

        self._server = _Server((host, port), _Handler)
        self.address: tuple[str, int] = self._server.server_address[:2]  # type: ignore[assignment]
        self._thread = threading.Thread(
            target=self._server.serve_forever, name="sim-control", daemon=True
        )

    @property
    def endpoint(self) -> str:
        return f"control://{self.address[0]}:{self.address[1]}"

    def start(self) -> ControlServer:
        self._thread.start()
        return self

    def close(self) -> None:
        self._server.shutdown()
        self._server.server_close()

    def __enter__(self) -> ControlServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def execute(self, line: str) -> str:
        """Carry out one command line; the answer line (``ok`` or ``error: ...``)."""
        try:
            words = line.split()
            if not words:
                raise UsageError("empty line")
            verb, args = words[0].lower(), words[1:]
            if verb == "input" and len(args) in (3, 4):
                port = _number("port", args[0])
                contact = _number("contact", args[1])
                on = _switch(args[2])
                host = self._host(args[3:])
                with host.lock:
                    model = _controller_of(host).model
                    if not 0 <= port < len(model.inputs):
                        raise UsageError(f"port {port} is not 0..{len(model.inputs) - 1}")
                    if not 0 <= contact <= 15:
                        raise UsageError(f"contact {contact} is not 0..15")
                    model.set_input(port, contact, on)
                host.wake()
                return "ok"
            if verb == "alarm" and 1 <= len(args) <= 3:
                code = _number("alarm code", args[0])
                if code not in set(AlarmCode):
                    raise UsageError(f"alarm code {code} is not one of {_ALARM_CODES}")
                channel = _number("channel", args[1]) if len(args) > 1 else ALL_CHANNELS
                host = self._host(args[2:])
                with host.lock:
                    model = _controller_of(host).model
                    channels = len(model.channels)
                    if channel != ALL_CHANNELS and not 1 <= channel <= channels:
                        raise UsageError(
                            f"channel {channel} is not 1..{channels} (or {ALL_CHANNELS} for all)"
                        )
                    model.raise_alarm(code, channel)
                host.wake()
                return "ok"
            raise UsageError(
                "expected 'input PORT CONTACT on|off [CTRL]' or 'alarm CODE [CHANNEL] [CTRL]'"
            )
        except UsageError as error:
            return f"error: {error}"

    def _host(self, rest: Sequence[str]) -> PeerHost:
        index = _number("controller", rest[0]) if rest else 1
        if not 1 <= index <= len(self.hosts):
            raise UsageError(f"controller {index} is not 1..{len(self.hosts)}")
        return self.hosts[index - 1]


def send_control(address: tuple[str, int], line: str, timeout: float = 5.0) -> str:
    """Send one control line to a running simulator and return its answer line."""
    with socket.create_connection(address, timeout=timeout) as sock:
        sock.sendall(line.encode() + b"\n")
        answer = b""
        while not answer.endswith(b"\n"):
            chunk = sock.recv(4096)
            if not chunk:
                break
            answer += chunk
    return answer.decode("utf-8", "replace").strip()
