"""How long one message takes to cross each kind of line the simulator serves, with no pacing.

A message written to a pseudo-terminal reaches its reader only after the kernel's tty layer has
run it through a worker thread; over loopback TCP it is handed across at once. Neither is a
serial line's behaviour, and the paced simulator cannot see when a pseudo-terminal's bytes were
written (a terminal has no receive stamps), so on a pty every host message costs this hop on
top of its wire time: the part of item 3's "line" share that no client and no simulator can
remove. Measured as half the round trip of one byte echoed by another process, raw mode.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import termios
import time
import tty

from bench.measure import median

__all__ = ["one_way_seconds"]

_ECHO = """
import os, socket, sys, termios, tty
kind, where = sys.argv[1], sys.argv[2]
if kind == "pty":
    fd = os.open(where, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd, termios.TCSANOW)
    read, write = (lambda: os.read(fd, 64)), (lambda b: os.write(fd, b))
else:
    host, port = where.rsplit(":", 1)
    sock = socket.create_connection((host, int(port)))
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    read, write = (lambda: sock.recv(64)), sock.sendall
while True:
    data = read()
    if not data or data == b"q":
        break
    write(data)
"""


def one_way_seconds(kind: str, pings: int = 500, gap: float = 0.001) -> float:
    """Median one-way time of a one-byte message over ``kind`` ("pty" or "tcp"), the pings
    ``gap`` seconds apart (as an exchange's messages are: both sides sleep between them)."""
    if kind == "pty":
        master, slave = os.openpty()
        tty.setraw(master, termios.TCSANOW)
        where = os.ttyname(slave)
        read, write = (lambda: os.read(master, 64)), (lambda b: os.write(master, b))
        closers = [lambda: os.close(master), lambda: os.close(slave)]
    else:
        listener = socket.create_server(("127.0.0.1", 0))
        host, port = listener.getsockname()[:2]
        where = f"{host}:{port}"
        closers = [listener.close]
    echo = subprocess.Popen([sys.executable, "-c", _ECHO, kind, where])
    try:
        if kind != "pty":
            listener.settimeout(10.0)
            sock, _ = listener.accept()
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            read, write = (lambda: sock.recv(64)), sock.sendall
            closers.append(sock.close)
        trips = []
        for _ in range(pings):
            time.sleep(gap)
            sent = time.perf_counter()
            write(b"x")
            if read() != b"x":
                raise RuntimeError(f"{kind} echo: not the byte sent")
            trips.append(time.perf_counter() - sent)
        write(b"q")
        echo.wait(10.0)
    finally:
        if echo.poll() is None:
            echo.kill()
            echo.wait()
        for close in closers:
            close()
    return median(trips[pings // 10 :]) / 2  # the first tenth warms up
