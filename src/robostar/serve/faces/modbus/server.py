"""The pymodbus glue: one asyncio Modbus TCP server per line, its tables laid out as the map,
every request passed through :class:`RegisterSource` (reads answered from the model, writes to
the command block checked and handed to the handshake).

pymodbus's ``SimDevice`` holds four tables (coils, discrete inputs, holding and input
registers); its ``action`` hook sees each request before pymodbus answers it and may refresh the
registers or answer with an exception. Coils are not mapped: every coil request is answered
ILLEGAL DATA ADDRESS, as is a write to a read-only register (pymodbus checks that itself) and
any address past a table's end.

Connections are bounded: one from a peer not in ``allow_from`` (loopback always is) is closed
at once, as is one past ``max_clients`` (the PLC's client tries again), and one that sends
nothing for ``idle_timeout`` seconds is closed, so that PLCs that lost power or their cable (a
half-open connection lives for ever) do not keep the places of the PLCs that come back.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Sequence
from typing import Any, Protocol

from pymodbus.constants import ExcCodes
from pymodbus.pdu.device import ModbusDeviceIdentification
from pymodbus.server import ModbusTcpServer
from pymodbus.server.requesthandler import ServerRequestHandler
from pymodbus.simulator import DataType, SimData, SimDevice

from robostar import __version__
from robostar.errors import UsageError
from robostar.listen import Network, admits, check_host
from robostar.serve.faces.modbus.image import Image
from robostar.serve.faces.modbus.layout import DI, HR, IR, MAP_VERSION
from robostar.transport.url import netloc

__all__ = ["RegisterServer", "RegisterSource"]

log = logging.getLogger("robostar.serve.modbus")

_TURNED_AWAY_WARNING = 60.0
"""Seconds between two warnings of connections turned away past ``max_clients``."""
_READ_DI = 2
_READ_IR = 4
_HOLDING = frozenset((3, 6, 16, 22, 23))
_COILS = frozenset((1, 5, 15))


class RegisterSource(Protocol):
    """What a line's server asks of the face."""

    def image(self) -> Image:
        """The input registers and discrete inputs as of now."""

    def results(self) -> list[int]:
        """The handshake's read-only registers, HR.DONE_SEQUENCE to HR.SIZE."""

    def check_write(self, address: int, values: Sequence[int]) -> ExcCodes | None:
        """An exception for a write the command block refuses (a bad value), else None."""

    def written(self, block: list[int]) -> None:
        """The command block (HR 0-9) after a write that was accepted."""


def identity() -> ModbusDeviceIdentification:
    """What Read Device Identification (function 43/14) and Report Server ID (17) answer, so
    that a commissioning tool's scan names the server and its map (pymodbus keeps one for the
    whole process: it names no line)."""
    return ModbusDeviceIdentification(  # type: ignore[no-untyped-call]
        info_name={
            "VendorName": "robostar",
            "ProductCode": "robostar-serve-modbus",
            "MajorMinorRevision": __version__,
            "ProductName": "robostar line server, Modbus TCP face",
            "ModelName": f"register map version {MAP_VERSION}",
        }
    )


def _pack_bits(bits: Sequence[bool]) -> list[int]:
    """Bits as pymodbus keeps them: 16 to a register, bit 0 in the lowest bit."""
    words = []
    for start in range(0, len(bits), 16):
        word = 0
        for i, on in enumerate(bits[start : start + 16]):
            if on:
                word |= 1 << i
        words.append(word)
    return words


class _Connection(ServerRequestHandler):
    """One client's connection: closed at once when its peer is not in the listener's
    ``allow_from`` or the listener has its ``max_clients`` already, and when it has sent
    nothing for its ``idle_timeout``."""

    def __init__(self, listener: _Listener) -> None:
        super().__init__(  # type: ignore[no-untyped-call]
            listener, listener.trace_packet, listener.trace_pdu, listener.trace_connect
        )
        self.owner = listener
        self.heard = listener.loop.time()
        self._timer: asyncio.TimerHandle | None = None

    def callback_connected(self) -> None:
        super().callback_connected()
        owner = self.owner
        peer = self.transport.get_extra_info("peername") if self.transport else None
        if not admits(owner.allow_from, peer):
            owner.turned_away(f"not in allow_from ({peer[0] if peer else '?'})")
            self.close()
            return
        if len(owner.active_connections) > owner.max_clients:  # this one is counted
            owner.turned_away(f"{owner.max_clients} clients already (max_clients)")
            self.close()
            return
        if owner.idle_timeout:
            self._timer = owner.loop.call_later(owner.idle_timeout, self._check_idle)

    def callback_data(self, data: bytes, addr: tuple[Any, ...] | None = None) -> int:
        self.heard = self.owner.loop.time()
        return super().callback_data(data, addr)

    def _check_idle(self) -> None:
        self._timer = None
        if not self.transport or not self.owner.idle_timeout:
            return
        silent = self.owner.loop.time() - self.heard
        if silent >= self.owner.idle_timeout:
            log.info(
                "modbus %s: a connection closed: silent for %.0f s (idle_timeout)",
                self.owner.line_name,
                silent,
            )
            self.close()
        else:
            remaining = self.owner.idle_timeout - silent
            self._timer = self.owner.loop.call_later(remaining, self._check_idle)

    def _cancel_timer(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def callback_disconnected(self, exc: Exception | None) -> None:
        self._cancel_timer()
        super().callback_disconnected(exc)

    def close(self, reconnect: bool = False) -> None:
        self._cancel_timer()
        super().close(reconnect)


class _Listener(ModbusTcpServer):
    """pymodbus's TCP server, its connections bounded (see :class:`_Connection`)."""

    def __init__(
        self,
        *args: Any,
        line_name: str,
        max_clients: int,
        idle_timeout: float,
        allow_from: tuple[Network, ...] | None,
        **kwargs: Any,
    ) -> None:
        super().__init__(*args, **kwargs)
        self.line_name = line_name
        self.max_clients = max_clients
        self.idle_timeout = idle_timeout
        self.allow_from = allow_from
        self._turned_away: dict[str, int] = {}
        self._warned_at: dict[str, float] = {}

    def turned_away(self, why: str) -> None:
        """Count a connection turned away; say so at most once a minute for each ``why`` (a
        PLC's client tries again and again, each time turned away)."""
        self._turned_away[why] = self._turned_away.get(why, 0) + 1
        now = self.loop.time()
        warned = self._warned_at.get(why)
        if warned is not None and now - warned < _TURNED_AWAY_WARNING:
            return
        log.warning(
            "modbus %s: %d connection(s) turned away: %s",
            self.line_name,
            self._turned_away.pop(why),
            why,
        )
        self._warned_at[why] = now

    def callback_new_connection(self) -> _Connection:
        return _Connection(self)


class RegisterServer:
    """The Modbus TCP server of one line (see the module docstring): at most ``max_clients``
    connections, each closed after ``idle_timeout`` seconds of silence (0: never)."""

    def __init__(
        self,
        name: str,
        source: RegisterSource,
        *,
        writes: bool,
        max_clients: int = 16,
        idle_timeout: float = 120.0,
        allow_from: tuple[Network, ...] | None = None,
    ) -> None:
        self.name = name
        self.allow_from = allow_from
        self.source = source
        self.writes = writes
        self.max_clients = max_clients
        self.idle_timeout = idle_timeout
        self.address: tuple[str, int] | None = None
        self._server: _Listener | None = None
        self._packed: tuple[list[bool], list[int]] | None = None
        """The discrete inputs last packed, and their packing (they change with the model)."""

    def device(self) -> SimDevice:
        """The tables: coils (present, never answered), discrete inputs, holding registers
        (0-9 writable when writes are on; the results read-only), input registers."""
        writable = SimData(
            HR.COMMAND, count=HR.WRITABLE, datatype=DataType.REGISTERS, readonly=not self.writes
        )
        results = SimData(
            HR.WRITABLE, count=HR.SIZE - HR.WRITABLE, datatype=DataType.REGISTERS, readonly=True
        )
        return SimDevice(
            0,  # every unit id: a PLC may address the face as unit 0, 1 or 255
            simdata=(
                [SimData(0, values=[False] * 16, datatype=DataType.BITS)],
                [SimData(0, values=[False] * DI.SIZE, datatype=DataType.BITS, readonly=True)],
                [writable, results],
                [SimData(0, count=IR.SIZE, datatype=DataType.REGISTERS, readonly=True)],
            ),
            action=self._action,
        )

    async def start(self, host: str, port: int, *, allow_remote: bool) -> tuple[str, int]:
        check_host(host, allow_remote)
        server = _Listener(
            self.device(),
            address=(host, port),
            line_name=self.name,
            max_clients=self.max_clients,
            idle_timeout=self.idle_timeout,
            allow_from=self.allow_from,
            identity=identity(),
        )
        try:
            await server.serve_forever(background=True)
        except RuntimeError as exc:
            raise UsageError(
                f"modbus.lines.{self.name}: cannot listen on {netloc(host, port)}"
                " (is the port in use?)"
            ) from exc
        self._server = server
        listener = server.transport
        sockets = getattr(listener, "sockets", None) or ()
        bound = sockets[0].getsockname() if sockets else (host, port)
        self.address = (str(bound[0]), int(bound[1]))
        return self.address

    @property
    def connections(self) -> int:
        """The clients connected now."""
        return 0 if self._server is None else len(self._server.active_connections)

    async def stop(self) -> None:
        server, self._server = self._server, None
        if server is not None:
            await server.shutdown()  # type: ignore[no-untyped-call]

    async def _action(
        self,
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        registers: list[int],
        values: list[int] | list[bool] | None,
    ) -> ExcCodes | None:
        """pymodbus's hook, before it answers: refresh what is read, check what is written."""
        if function_code in _COILS:
            return ExcCodes.ILLEGAL_ADDRESS
        if function_code == _READ_IR:
            registers[: IR.SIZE] = self.source.image().input_registers
        elif function_code == _READ_DI:
            bits = self.source.image().discrete_inputs
            if self._packed is None or self._packed[0] is not bits:
                self._packed = (bits, _pack_bits(bits))
            registers[: DI.SIZE // 16] = self._packed[1]
        elif function_code in _HOLDING:
            registers[HR.WRITABLE : HR.SIZE] = self.source.results()
            if values:
                words = [int(v) for v in values]
                problem = self.source.check_write(address, words)
                if problem is not None:
                    return problem
                block = list(registers[: HR.WRITABLE])
                for i, word in enumerate(words):
                    if address + i < HR.WRITABLE:
                        block[address + i] = word
                self.source.written(block)
        return None
