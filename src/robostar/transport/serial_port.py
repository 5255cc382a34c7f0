"""Serial transport over pyserial: a device path or a pyserial URL, with useful open errors."""

from __future__ import annotations

import contextlib
import errno
import os
import select
import sys
from dataclasses import asdict, dataclass
from typing import Any

import serial

from robostar.errors import PortError
from robostar.transport.base import Transport
from robostar.transport.url import DEFAULT_BAUDRATE

__all__ = ["SerialSettings", "SerialTransport", "port_error"]

_BUSY = frozenset((errno.EBUSY, errno.EAGAIN, errno.EWOULDBLOCK))
_DENIED = frozenset((errno.EACCES, errno.EPERM))
_READ_SIZE = 4096
"""At most this much per read: more than a few packets of the N1's."""


def port_error(port: str, exc: BaseException) -> PortError:
    """A PortError saying whether ``port`` is missing, busy or not permitted, and what to do."""
    code = getattr(exc, "errno", None)
    text = str(exc)
    if code == errno.ENOENT or "FileNotFoundError" in text or "No such file" in text:
        names = "(COM1, COM3, ...)" if sys.platform == "win32" else "(ls /dev/ttyUSB* /dev/ttyS*)"
        hint = f"no such port; check the cable and the adapter, and the name {names}"
    elif code in _BUSY or "exclusively lock" in text:
        hint = "the port is busy; another program has it open - close that program first"
    elif sys.platform == "win32" and ("PermissionError" in text or "Access is denied" in text):
        # Windows answers "access denied" for a COM port that another program holds.
        hint = "the port is busy; another program has it open - close that program first"
    elif code in _DENIED or "Permission denied" in text:
        hint = (
            "permission denied; add yourself to the dialout group "
            "(sudo usermod -aG dialout $USER, then log out and in again)"
        )
    else:
        hint = f"could not open the port: {text}"
    error = PortError(f"{port}: {hint}")
    error.errno = code
    return error


@dataclass(frozen=True, slots=True)
class SerialSettings:
    """Line settings; the defaults are the N1's (manual 3.5): 115200 baud, 8N1, no flow control."""

    baudrate: int = DEFAULT_BAUDRATE
    bytesize: int = 8
    parity: str = "N"
    stopbits: float = 1
    rtscts: bool = False
    xonxoff: bool = False
    dsrdtr: bool = False

    def as_kwargs(self) -> dict[str, Any]:
        """For pyserial's constructors."""
        return asdict(self)


def _descriptor(port: serial.SerialBase) -> int | None:
    """The port's file descriptor to wait on with select, where it has one (POSIX)."""
    if sys.platform == "win32":
        return None
    try:
        fd: int = port.fileno()
    except (AttributeError, OSError):  # pyserial's loop:// and the like have none
        return None
    return fd


class SerialTransport(Transport):
    """A serial device (``/dev/ttyUSB0``, ``COM3``) or a pyserial URL (``socket://``, ...).

    Defaults are the N1's: 115200 baud, 8N1, no flow control. On Linux the adapter is put in
    low-latency mode where it allows it (FTDI adapters otherwise hold bytes for 16 ms), and the
    port is locked so that a second program cannot interleave bytes on the same line.
    """

    def __init__(
        self,
        port: str,
        *,
        is_url: bool = False,
        baudrate: int = DEFAULT_BAUDRATE,
        bytesize: int = 8,
        parity: str = "N",
        stopbits: float = 1,
        rtscts: bool = False,
        xonxoff: bool = False,
        dsrdtr: bool = False,
        exclusive: bool = True,
        low_latency: bool = True,
    ) -> None:
        self.url = port
        self.port = port
        self.is_url = is_url
        self.settings = SerialSettings(
            baudrate, bytesize, parity, stopbits, rtscts, xonxoff, dsrdtr
        )
        self.exclusive = exclusive
        self.low_latency = low_latency
        self._serial: serial.SerialBase | None = None
        self._fd: int | None = None
        self._direct = False
        """Read the device's descriptor with os.read (a device path on POSIX)."""

    @property
    def is_open(self) -> bool:
        return self._serial is not None

    @property
    def serial(self) -> serial.SerialBase | None:
        """The pyserial object while open (for settings this class does not cover)."""
        return self._serial

    def open(self) -> None:
        if self._serial is not None:
            return
        settings = self.settings.as_kwargs()
        try:
            if self.is_url:
                port: serial.SerialBase = serial.serial_for_url(self.port, **settings)
            else:
                port = serial.Serial(
                    self.port, exclusive=self.exclusive or None, timeout=0, **settings
                )
        except (serial.SerialException, OSError) as exc:
            raise port_error(self.port, exc) from exc
        except ValueError as exc:
            raise PortError(f"{self.port}: bad serial settings: {exc}") from exc
        port.timeout = 0
        if self.low_latency and not self.is_url:
            # A pty, a Bluetooth port or a non-Linux system has no such mode; no harm done.
            with contextlib.suppress(AttributeError, NotImplementedError, OSError, ValueError):
                port.set_low_latency_mode(True)  # type: ignore[attr-defined]
        self._fd = _descriptor(port)
        # pyserial opens a POSIX device non-blocking: once select() says it is readable, one
        # os.read() takes what is there. Through port.read() a read cost an ioctl (in_waiting),
        # a second select() and pyserial's timeout bookkeeping besides.
        self._direct = self._fd is not None and not self.is_url
        self._serial = port

    def close(self) -> None:
        port, self._serial = self._serial, None
        self._fd = None
        self._direct = False
        if port is not None:
            with contextlib.suppress(serial.SerialException, OSError):
                port.close()

    def write(self, data: bytes) -> None:
        port = self._serial
        if port is None:
            raise self._closed_error()
        try:
            port.write(data)
        except (serial.SerialException, OSError) as exc:
            self.close()
            raise PortError(f"{self.port}: write failed ({exc}); the line is closed") from exc

    def read(self, timeout: float) -> bytes:
        port = self._serial
        if port is None:
            raise self._closed_error()
        try:
            if self._fd is not None:
                # Wait with select on the descriptor: setting pyserial's timeout on every read
                # would reconfigure the port (tcsetattr) each time.
                ready, _, _ = select.select([self._fd], [], [], max(timeout, 0.0))
                if not ready:
                    return b""
                if self._direct:
                    try:
                        data = os.read(self._fd, _READ_SIZE)
                    except BlockingIOError:
                        return b""  # another reader took it first; as a timeout
                    if not data:  # pyserial's words for the same
                        raise serial.SerialException(
                            "device reports readiness to read but returned no data"
                            " (device disconnected or multiple access on port?)"
                        )
                    return data
                waiting: int = port.in_waiting  # type: ignore[attr-defined]
                return bytes(port.read(max(waiting, 1)))
            if port.timeout != timeout:
                port.timeout = max(timeout, 0.0)
            first = bytes(port.read(1))
            if not first:
                return b""
            waiting = port.in_waiting  # type: ignore[attr-defined]
            return first + (bytes(port.read(waiting)) if waiting else b"")
        except (serial.SerialException, OSError) as exc:
            self.close()
            raise PortError(f"{self.port}: read failed ({exc}); the line is closed") from exc
