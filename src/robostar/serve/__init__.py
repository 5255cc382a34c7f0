"""The line server: one process owns the controllers' lines and serves every consumer (faces)."""

from robostar.serve.audit import AuditError
from robostar.serve.config import ConfigError, LineConfig, ServeConfig, load_config
from robostar.serve.lease import Lease, LeaseHeldError, LeaseInfo, Who
from robostar.serve.line import AbortedByStopError, Line, LineBusyError, LineDownError, LineHealth
from robostar.serve.model import Change, ControllerModel, Quality, Sample, Subscription
from robostar.serve.server import LineServer

__all__ = [
    "AbortedByStopError",
    "AuditError",
    "Change",
    "ConfigError",
    "ControllerModel",
    "Lease",
    "LeaseHeldError",
    "LeaseInfo",
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
    "load_config",
]
