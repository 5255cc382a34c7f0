"""The line server: one process owns the controllers' lines and serves every consumer (faces)."""

from robostar.serve.audit import AuditError
from robostar.serve.config import ConfigError, LineConfig, ServeConfig, load_config
from robostar.serve.lease import Lease, LeaseHeldError, LeaseInfo, Who
from robostar.serve.lease_gate import LeaseLostError
from robostar.serve.line import Line, LineHealth
from robostar.serve.line_errors import (
    AbortedByStopError,
    LineBusyError,
    LineDownError,
    WithdrawnError,
)
from robostar.serve.line_server import LineServer
from robostar.serve.model import Change, ControllerModel, Quality, Sample, Subscription

__all__ = [
    "AbortedByStopError",
    "AuditError",
    "Change",
    "ConfigError",
    "ControllerModel",
    "Lease",
    "LeaseHeldError",
    "LeaseInfo",
    "LeaseLostError",
    "Line",
    "LineBusyError",
    "LineConfig",
    "LineDownError",
    "LineHealth",
    "LineServer",
    "Quality",
    "Sample",
    "ServeConfig",
    "Subscription",
    "Who",
    "WithdrawnError",
    "load_config",
]
