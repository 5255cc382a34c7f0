"""The ``robostar`` command: the technician's console for an N1 controller."""

from robostar.cli.app import cli, main

__all__ = ["cli", "main"]
