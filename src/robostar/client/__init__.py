"""The client library: :class:`Client` (blocking) and :class:`AsyncClient` (asyncio).

Both offer the same methods, written once (:mod:`robostar.client.surface`), over any transport
(:mod:`robostar.transport`); ``probe`` finds a controller's baud rate.
"""

from robostar.backup import BackupFile, Manifest
from robostar.client.aio import AsyncClient
from robostar.client.exchange import Progress
from robostar.client.jog import AsyncJog, Jog
from robostar.client.probe import BAUD_RATES, ProbeAttempt, ProbeResult, probe
from robostar.client.sync import Client
from robostar.client.trace import TraceRecord
from robostar.errors import (
    AlarmRaisedError,
    JogInterruptedError,
    WaitError,
    WaitTimeoutError,
)

__all__ = [
    "BAUD_RATES",
    "AlarmRaisedError",
    "AsyncClient",
    "AsyncJog",
    "BackupFile",
    "Client",
    "Jog",
    "JogInterruptedError",
    "Manifest",
    "ProbeAttempt",
    "ProbeResult",
    "Progress",
    "TraceRecord",
    "WaitError",
    "WaitTimeoutError",
    "probe",
]
