"""The simulator's control socket: change the outside world of a running simulator.

A loopback TCP socket taking one command per line, so that a test script or
``robostar sim-input`` can flip a sensor input or raise an alarm while clients talk to the
controllers over their own endpoints::

    input PORT CONTACT on|off [CTRL]     set an input contact (CTRL: controller 1..N, default 1)
    alarm CODE [CHANNEL] [CTRL]          raise an alarm (CHANNEL 1-3, default all)

Each line is answered ``ok`` or ``error: <why>``. Every change is made holding the controller
host's lock, as the hosts' own threads do.
"""

from __future__ import annotations

import socket
import socketserver
import threading
from collections.abc import Sequence
from typing import Any

from robostar.errors import UsageError
from robostar.serving.threaded import PeerHost
from robostar.sim.alarms import ALL_CHANNELS

__all__ = ["ControlServer", "send_control"]


def _controller_of(host: PeerHost) -> Any:
    """The VirtualController inside a host's peer (under any fault or pacing wrappers)."""
    peer: Any = host.peer
    if hasattr(peer, "controller"):
        return peer.controller
    while not hasattr(peer, "model"):
        peer = peer.peer
    return peer


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
                for raw in self.rfile:
                    line = raw.decode("utf-8", "replace").strip()
                    if line:
                        self.wfile.write((owner.execute(line) + "\n").encode())

        class _Server(socketserver.ThreadingTCPServer):
            daemon_threads = True
            allow_reuse_address = True

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
            verb, args = words[0].lower(), words[1:]
            if verb == "input" and len(args) in (3, 4):
                port, contact, on = int(args[0]), int(args[1]), _switch(args[2])
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
                code = int(args[0])
                channel = int(args[1]) if len(args) > 1 else ALL_CHANNELS
                if channel not in (1, 2, 3, ALL_CHANNELS):
                    raise UsageError(f"channel {channel} is not 1-3 (or 9 for all)")
                host = self._host(args[2:])
                with host.lock:
                    _controller_of(host).model.raise_alarm(code, channel)
                host.wake()
                return "ok"
            raise UsageError(
                "expected 'input PORT CONTACT on|off [CTRL]' or 'alarm CODE [CHANNEL] [CTRL]'"
            )
        except (UsageError, ValueError, IndexError) as error:
            return f"error: {error}"

    def _host(self, rest: Sequence[str]) -> PeerHost:
        index = int(rest[0]) if rest else 1
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
