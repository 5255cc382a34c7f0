"""A loopback TCP relay that holds every chunk a while in each direction, as a serial device
server with latency does (tests of what arrives late)."""

from __future__ import annotations

import contextlib
import socket
import threading
import time

from robostar.protocol.frame import RST


class DelayRelay:
    """A loopback TCP relay that delivers every chunk ``delay`` s after it arrived, in order,
    both ways; it records when each chunk from the client arrived."""

    def __init__(self, target: tuple[str, int], delay: float) -> None:
        self.target = target
        self.delay = delay
        self.answer_delay = 0.0
        """Held this much longer on the way back (a controller slow to answer)."""
        self.from_client: list[tuple[float, bytes]] = []
        self.listener = socket.create_server(("127.0.0.1", 0))
        host, port = self.listener.getsockname()[:2]
        self.url = f"tcp://{host}:{port}"
        self._threads: list[threading.Thread] = []
        self._accept = threading.Thread(target=self._serve, daemon=True)
        self._accept.start()

    def _serve(self) -> None:
        try:
            client, _ = self.listener.accept()
        except OSError:
            return
        upstream = socket.create_connection(self.target)
        for sock in (client, upstream):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._pipe(client, upstream, record=True)
        self._pipe(upstream, client, record=False, back=True)

    def _pipe(
        self, src: socket.socket, dst: socket.socket, *, record: bool, back: bool = False
    ) -> None:
        queue: list[tuple[float, bytes]] = []
        ready = threading.Condition()

        def reader() -> None:
            while True:
                try:
                    data = src.recv(4096)
                except OSError:
                    data = b""
                now = time.monotonic()
                if record and data:
                    self.from_client.append((now, data))
                with ready:
                    queue.append((now + self.delay + (self.answer_delay if back else 0.0), data))
                    ready.notify()
                if not data:
                    return

        def writer() -> None:
            while True:
                with ready:
                    while not queue:
                        ready.wait()
                    due, data = queue.pop(0)
                time.sleep(max(0.0, due - time.monotonic()))
                if not data:
                    with contextlib.suppress(OSError):
                        dst.shutdown(socket.SHUT_WR)
                    return
                try:
                    dst.sendall(data)
                except OSError:
                    return

        for target in (reader, writer):
            thread = threading.Thread(target=target, daemon=True)
            thread.start()
            self._threads.append(thread)

    def sent_at(self, frame: bytes) -> float:
        """When the client's write holding ``frame`` reached the relay."""
        return next(at for at, data in self.from_client if frame in data)

    def rst_at(self) -> float:
        return next(at for at, data in self.from_client if bytes((RST,)) in data)

    def close(self) -> None:
        self.listener.close()
