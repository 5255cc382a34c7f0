"""The Modbus face: a Modbus TCP server per line, answering from the line's model.

The PLC's reads never reach the serial line: the line's poller keeps the model fresh, and the
face answers each read from it, with every block's age and quality beside the values. The face
reads the configured global variables itself, every ``globals_interval`` (they are not polled
by the line), and the JOB list (FD) when the selected JOB's number is not known yet.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from pymodbus.constants import ExcCodes

from robostar.commands.base import Command
from robostar.commands.variables import ReadGlobalFloat, ReadGlobalInt
from robostar.errors import RobostarError
from robostar.listen import warn_remote
from robostar.serve.faces.modbus.handshake import CODES
from robostar.serve.faces.modbus.image import Image, ImageInputs, build_image
from robostar.serve.faces.modbus.layout import HR
from robostar.serve.faces.modbus.runner import CommandRunner, JobTable
from robostar.serve.faces.modbus.server import RegisterServer
from robostar.serve.faces.modbus.settings import ModbusSettings
from robostar.serve.lease import Who
from robostar.serve.model import Quality, Sample

if TYPE_CHECKING:
    from robostar.serve.line import Line
    from robostar.serve.line_server import LineServer

__all__ = ["LinePort", "ModbusFace"]

log = logging.getLogger("robostar.serve.modbus")

_JOB_LIST_INTERVAL = 10.0
"""Seconds between reads of a channel's JOB list while its selected JOB's number is unknown."""


class LinePort:
    """One line's map: its image, its command block, its own reads (globals, JOB list)."""

    def __init__(self, line: Line, settings: ModbusSettings) -> None:
        self.line = line
        self.settings = settings
        self.jobs = JobTable(line)
        self.runner = CommandRunner(
            line, Who(settings.holder, "modbus"), settings.commands, self.jobs
        )
        self.global_ints: dict[int, Sample] = {}
        self.global_floats: dict[int, Sample] = {}
        self._job_list_read: dict[int, float] = {}
        self._changes = line.model.subscribe(maxsize=256)
        """Only as a signal: a quality changed (marks and age-outs do not count as updates)."""
        self._globals_read = 0
        self._image: Image | None = None
        self._key: tuple[object, ...] = ()

    def close(self) -> None:
        self._changes.close()

    # -- RegisterSource --------------------------------------------------------------------
    def image(self) -> Image:
        """The map as of now. Rebuilt only when something it shows may have changed (a value
        stored, a quality changed, a global read, the line up or down, a JOB list read);
        otherwise only the ages move: a PLC's many reads between two polls cost little."""
        key = (self.line.model.updates, self.line.up, self._globals_read, self.jobs.reads)
        changed = self._changes.pending() > 0
        while self._changes.get_nowait() is not None:
            pass
        now = time.time()
        if self._image is None or changed or key != self._key:
            self._image = self._build(now)
            self._key = key
        else:
            self._image.set_ages(now)
        return self._image

    def _build(self, now: float) -> Image:
        inputs = ImageInputs(
            samples=self.line.model.snapshot(),
            online=self.line.up,
            channels=self.line.channels(),
            io_ports=self.line.config.io_ports,
            ints=self.settings.ints,
            floats=self.settings.floats,
            global_ints=self.global_ints,
            global_floats=self.global_floats,
            job_numbers=self.jobs.numbers,
        )
        return build_image(inputs, now)

    def results(self) -> list[int]:
        return list(self.runner.registers)

    def check_write(self, address: int, values: Sequence[int]) -> ExcCodes | None:
        if address <= HR.COMMAND < address + len(values):
            code = values[HR.COMMAND - address]
            if code != 0 and code not in CODES:
                return ExcCodes.ILLEGAL_VALUE
        return None

    def written(self, block: list[int]) -> None:
        self.runner.submit(block)

    # -- the face's own reads --------------------------------------------------------------
    async def read_loop(self) -> None:
        """Globals and JOB lists, at the face's pace (not the PLC's)."""
        interval = self.settings.globals_interval
        while True:
            started = time.monotonic()
            if self.line.up:
                await self._read_globals()
                await self._read_job_lists()
            await asyncio.sleep(max(0.05, interval - (time.monotonic() - started)))

    async def _read_globals(self) -> None:
        s = self.settings
        for index in s.ints.indices:
            await self._read_global(self.global_ints, index, ReadGlobalInt(index))
        for index in s.floats.indices:
            await self._read_global(self.global_floats, index, ReadGlobalFloat(index))

    async def _read_global(
        self, store: dict[int, Sample], index: int, command: Command[Any]
    ) -> None:
        try:
            value = await self.line.read(command, max_age=self.settings.globals_interval)
        except RobostarError as exc:
            # the old value stays, but is no longer vouched for
            log.debug("modbus %s: %r not read: %s", self.line.name, command, exc)
            old = store.get(index)
            if old is not None:
                store[index] = Sample(old.value, old.at, Quality.STALE)
                self._globals_read += 1
            return
        store[index] = Sample(value, time.time())
        self._globals_read += 1

    async def _read_job_lists(self) -> None:
        now = time.monotonic()
        for channel in self.line.channels():
            sample = self.line.model.get(f"ch{channel}/job")
            if sample is None or sample.value is None:
                continue
            name = str(sample.value).upper()
            if name in self.jobs.numbers.get(channel, {}):
                continue
            if now < self._job_list_read.get(channel, 0.0) + _JOB_LIST_INTERVAL:
                continue
            self._job_list_read[channel] = now
            try:
                await self.jobs.refresh(channel)
            except RobostarError as exc:
                log.debug("modbus %s: channel %d JOB list: %s", self.line.name, channel, exc)


class ModbusFace:
    """A :class:`RegisterServer` per configured line (see the module docstring)."""

    def __init__(self, server: LineServer, settings: ModbusSettings) -> None:
        self.server = server
        self.settings = settings
        self.ports: dict[str, LinePort] = {}
        self.servers: dict[str, RegisterServer] = {}
        self.addresses: dict[str, tuple[str, int]] = {}
        self._tasks: list[asyncio.Task[None]] = []

    async def start(self) -> None:
        try:
            for name, (host, port) in self.settings.lines.items():
                line_port = LinePort(self.server.line(name), self.settings)
                modbus = RegisterServer(
                    name,
                    line_port,
                    writes=self.settings.writes,
                    max_clients=self.settings.max_clients,
                    idle_timeout=self.settings.idle_timeout,
                    allow_from=self.settings.allow_from,
                )
                self.addresses[name] = await modbus.start(
                    host, port, allow_remote=self.settings.allow_remote
                )
                self.ports[name] = line_port
                self.servers[name] = modbus
                warn_remote(host, self.addresses[name][1], f"the Modbus face of line {name}")
                self._tasks.append(
                    asyncio.create_task(line_port.read_loop(), name=f"modbus {name} reads")
                )
                log.info("modbus face: line %s on %s:%d", name, *self.addresses[name])
        except BaseException:
            await self.stop()
            raise

    async def stop(self) -> None:
        for modbus in self.servers.values():
            await modbus.stop()
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        for line_port in self.ports.values():
            await line_port.runner.stop()
            line_port.close()
        self._tasks.clear()
        self.servers.clear()
        self.ports.clear()
        self.addresses.clear()
