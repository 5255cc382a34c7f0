"""A raw host for item 3: the same transfers as the client, with no protocol stack.

Every packet is encoded before the clock starts; the loop only writes them, reads frames up to
ETX and LRC, and ACKs. Against the paced simulator it shows what the simulator and the
line (loopback TCP hops, or the kernel's pseudo-terminal) alone add to the wire time, so the
rest of the excess is the client's.
"""

from __future__ import annotations

import os
import select
import socket
import termios
import tty

from bench.floor import bound
from robostar.commands.files import DownloadFile, UploadFile
from robostar.commands.status import ReadStatus
from robostar.commands.system import ReadParameters
from robostar.protocol.frame import ACK, encode_packet

__all__ = ["RawHost", "download_request", "parameter_request", "upload_packets"]

_FLAG_END = 0x34


_PTY_WAIT = 5.0
"""Seconds a pseudo-terminal read waits for the simulator before the host gives up."""


class _Socket:
    """A blocking TCP socket, its reads bounded by SO_RCVTIMEO."""

    def __init__(self, url: str) -> None:
        host, port = url.removeprefix("tcp://").rsplit(":", 1)
        self.sock = socket.create_connection((host, int(port)))
        self.sock.settimeout(None)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        bound(self.sock)

    def write(self, data: bytes) -> None:
        self.sock.sendall(data)

    def read(self) -> bytes:
        return self.sock.recv(4096)

    def close(self) -> None:
        self.sock.close()


class _Terminal:
    """A pseudo-terminal's device in raw mode (8 data bits, no echo, no line editing)."""

    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd, termios.TCSANOW)

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.fd, view) :]

    def read(self) -> bytes:
        if not select.select([self.fd], [], [], _PTY_WAIT)[0]:
            raise TimeoutError(f"no answer from the simulator in {_PTY_WAIT} s")
        return os.read(self.fd, 4096)

    def close(self) -> None:
        os.close(self.fd)


class RawHost:
    """A blocking line to ``tcp://host:port`` or a pseudo-terminal's path that runs
    pre-encoded exchanges."""

    def __init__(self, url: str) -> None:
        self.line = _Socket(url) if url.startswith("tcp://") else _Terminal(url)
        self._buf = b""
        self.moved = 0
        """Bytes written and read so far."""

    def close(self) -> None:
        self.line.close()

    def _send(self, data: bytes) -> None:
        self.line.write(data)
        self.moved += len(data)

    def _frame(self) -> bytes:
        """The next whole packet (STX to LRC), or a lone control byte."""
        while True:
            buf = self._buf
            if buf and buf[0] != 0x02:
                self._buf = buf[1:]
                self.moved += 1
                return buf[:1]
            end = buf.find(b"\x03")
            if end >= 0 and len(buf) > end + 1:
                self._buf = buf[end + 2 :]
                self.moved += end + 2
                return buf[: end + 2]
            chunk = self.line.read()
            if not chunk:
                raise EOFError("the simulator closed the connection")
            self._buf += chunk

    def polls(self, count: int) -> None:
        request = encode_packet(ReadStatus().encode())
        for _ in range(count):
            self._send(request)
            self._frame()
            self._send(bytes((ACK,)))

    def download(self, request: bytes) -> int:
        """A multi-packet answer (FA, KE; ``request`` framed): ACK every packet up to END;
        returns the packet count."""
        self._send(request)
        packets = 0
        while True:
            frame = self._frame()
            self._send(bytes((ACK,)))
            packets += 1
            if frame[2] == _FLAG_END:
                return packets

    def upload(self, packets: list[bytes]) -> None:
        """FB (packets from :func:`upload_packets`): each packet, then the reply to it; the
        closing packet is answered by a lone ACK."""
        for packet in packets[:-1]:
            self._send(packet)
            self._frame()
        self._send(packets[-1])
        if self._frame() != bytes((ACK,)):
            raise RuntimeError("FB: the simulator did not close the upload with ACK")


def upload_packets(command: UploadFile) -> list[bytes]:
    """FB's framed packets: the request, one per line, the closing 0x34."""
    lines = [encode_packet(b"\x30" + body) for body in command.upload_bodies()]
    return [encode_packet(command.encode()), *lines, encode_packet(bytes((_FLAG_END,)))]


def download_request(command: DownloadFile) -> bytes:
    return encode_packet(command.encode())


def parameter_request(index: int) -> bytes:
    """KE of one public parameter group, framed."""
    return encode_packet(ReadParameters(None, index).encode())
