"""The console's fixtures (tests/cli/conftest.py) for the backup tests, which drive backups
and restores through the `robostar` command as well as through the client."""

from __future__ import annotations

from tests.cli.conftest import (
    AsJson,
    RealControllerStandIn,
    Run,
    SimLine,
    as_json,
    on,
    run,
    served,
    sim_line,
)

__all__ = [
    "AsJson",
    "RealControllerStandIn",
    "Run",
    "SimLine",
    "as_json",
    "on",
    "run",
    "served",
    "sim_line",
]
