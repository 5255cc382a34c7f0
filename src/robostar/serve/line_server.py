"""The line server: every configured line, the audit log and the faces, run as one."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from types import TracebackType
from typing import Self

from robostar.client.aio import AsyncClient
from robostar.serve.audit import AuditLog
from robostar.serve.config import LineConfig, ServeConfig
from robostar.serve.faces import Face, create_face
from robostar.serve.line import Line

__all__ = ["LineServer"]

log = logging.getLogger("robostar.serve")


class LineServer:
    """Owns the lines of ``config`` and runs its faces; use ``async with`` or start()/stop()."""

    def __init__(
        self,
        config: ServeConfig,
        *,
        client_factory: Callable[[LineConfig], AsyncClient] | None = None,
    ) -> None:
        """``client_factory`` makes each line's client (tests: a simulator behind a wrapper)."""
        self.config = config
        self.audit = AuditLog(config.audit_path)
        self.lines: dict[str, Line] = {
            lc.name: Line(
                lc, audit=self.audit, lease_ttl=config.lease_ttl, client_factory=client_factory
            )
            for lc in config.lines
        }
        self.faces: dict[str, Face] = {}
        self._started = False

    def line(self, name: str) -> Line:
        """The line called ``name``; KeyError names the known ones."""
        try:
            return self.lines[name]
        except KeyError:
            raise KeyError(f"no line {name!r} (lines: {', '.join(self.lines) or 'none'})") from None

    async def start(self) -> None:
        """Open every line (one attempt each: a down line keeps retrying), then the faces."""
        self.audit.open()  # a log that cannot be written stops the start, with its reason
        self._started = True
        await asyncio.gather(*(line.start() for line in self.lines.values()))
        try:
            for name, options in self.config.faces.items():
                face = create_face(name, self, options)
                await face.start()
                self.faces[name] = face
        except BaseException:
            await self.stop()
            raise

    async def stop(self) -> None:
        """Stop the faces (newest first), then the lines (jogs stopped, queues failed)."""
        for name in reversed(list(self.faces)):
            face = self.faces.pop(name)
            try:
                await face.stop()
            except Exception:
                log.exception("face %s did not stop cleanly", name)
        await asyncio.gather(*(line.stop() for line in self.lines.values()))
        self.audit.close()
        self._started = False

    async def __aenter__(self) -> Self:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.stop()
