"""Server processes for the benchmarks: start one, wait for the endpoints it prints, stop it.

Every server runs in a process of its own, so that the client's CPU figures are the client's
alone and the two sides do not share one interpreter lock (on the shop floor they do not share
a machine at all).
"""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from types import TracebackType
from typing import Self

import psutil

__all__ = ["REPO", "ServerProcess", "sim_command"]

REPO = Path(__file__).resolve().parent.parent
_STOP_WAIT = 10.0


def sim_command(
    count: int = 1,
    baud: int | None = None,
    *,
    pty: bool = False,
    state: str | os.PathLike[str] | None = None,
) -> list[str]:
    """``python -m robostar.sim`` serving ``count`` controllers on free loopback ports, or with
    ``pty`` on a pseudo-terminal only; ``state``: the directory it keeps its state in."""
    args = [sys.executable, "-m", "robostar.sim", "--count", str(count)]
    args += ["--listen", "none", "--pty"] if pty else ["--listen", "127.0.0.1:0"]
    if baud is not None:
        args += ["--baud", str(baud)]
    if state is not None:
        args += ["--state", os.fspath(state)]
    return args


class ServerProcess:
    """A server process that prints ``ready_lines`` endpoint lines on stdout once it serves.

    Use as a context manager; :attr:`lines` holds the endpoints. The process gets SIGTERM when
    the block ends (SIGKILL if it has not stopped after 10 s).
    """

    def __init__(self, args: list[str], *, ready_lines: int = 1, timeout: float = 60.0) -> None:
        self.args = args
        self.ready_lines = ready_lines
        self.timeout = timeout
        self.lines: list[str] = []
        self._proc: subprocess.Popen[str] | None = None
        # Kept open for the server's lifetime (closed in __exit__): its stderr, for errors.
        self._stderr = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115

    @property
    def pid(self) -> int:
        if self._proc is None:
            raise RuntimeError("server not started")
        return self._proc.pid

    def cpu_seconds(self) -> float:
        """User + system CPU the server has used so far (all its threads)."""
        times = psutil.Process(self.pid).cpu_times()
        return float(times.user + times.system)

    def rss_bytes(self) -> int:
        return int(psutil.Process(self.pid).memory_info().rss)

    def start(self) -> Self:
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(
            p for p in (str(REPO), str(REPO / "src"), env.get("PYTHONPATH", "")) if p
        )
        self._proc = subprocess.Popen(
            self.args,
            stdout=subprocess.PIPE,
            stderr=self._stderr,
            stdin=subprocess.DEVNULL,
            text=True,
            env=env,
            cwd=REPO,
        )
        self._wait_ready()
        return self

    def _wait_ready(self) -> None:
        proc = self._proc
        assert proc is not None and proc.stdout is not None
        # A thread reads stdout: a select on a buffered pipe misses lines already buffered,
        # and a server must never block on a full pipe later on.
        lines: queue.Queue[str] = queue.Queue()
        stdout = proc.stdout

        def pump() -> None:
            for line in stdout:
                lines.put(line)
            lines.put("")

        threading.Thread(target=pump, name="server-stdout", daemon=True).start()
        end = time.monotonic() + self.timeout
        while len(self.lines) < self.ready_lines:
            try:
                line = lines.get(timeout=max(end - time.monotonic(), 0.001))
            except queue.Empty:
                self.stop()
                raise RuntimeError(f"{self.args[1:4]}: not ready in {self.timeout:g} s") from None
            if not line:
                self.stop()
                raise RuntimeError(f"{self.args[1:4]} exited early:\n{self._stderr_tail()}")
            self.lines.append(line.strip())

    def _stderr_tail(self) -> str:
        self._stderr.seek(0)
        return self._stderr.read()[-2000:]

    def stop(self) -> None:
        proc = self._proc
        if proc is None or proc.poll() is not None:
            return
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(_STOP_WAIT)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(_STOP_WAIT)

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()
        self._stderr.close()
