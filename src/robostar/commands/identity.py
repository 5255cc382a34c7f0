"""The simulator's mark in its AD identity, made by the simulator and read by the console.

A technician's console must never let a simulator pass for the robot. Over ``sim://`` the URL
says so; over ``tcp://`` or a pseudo-terminal only the controller's AD answer can. The
simulator therefore always ends AD's VER with :data:`SIMULATOR_MARK`, whatever its
configuration says (:func:`simulator_version`), and :func:`is_simulator_identity` is the one
test of it.

VER is the firmware's own text (the manual's example is ``"N1RO 03.02.05-SB"``): a real N1
never ends it in ``-SIM``, and nobody at the machine can change it. NAME is not used: it is the
name set on the controller (the manual's "1.3.4.4 NAME"), so a real N1 named ``PRESS-SIM``
must not pass for a simulator either.

This lives beside the commands, below both the client and the simulator, so that the one
that writes the mark and the ones that read it share a single definition.
"""

from __future__ import annotations

from robostar.commands.status import VERSION_WIDTH
from robostar.types import ControllerInfo

__all__ = ["SIMULATOR_MARK", "is_simulator_identity", "simulator_version"]

SIMULATOR_MARK = "-SIM"
"""The end of every simulator's AD version."""


def simulator_version(version: str) -> str:
    """The version a simulator answers AD with: ``version`` ending in :data:`SIMULATOR_MARK`.

    A version that already ends in the mark (in any case) is kept as written; any other gets
    it appended, the text cut so that the whole still fits AD's 20-byte VER field
    (``"N1RO 03.02.05"`` -> ``"N1RO 03.02.05-SIM"``).
    """
    text = version.strip()
    if text.upper().endswith(SIMULATOR_MARK):
        return text
    return text[: VERSION_WIDTH - len(SIMULATOR_MARK)].rstrip() + SIMULATOR_MARK


def is_simulator_identity(info: ControllerInfo) -> bool:
    """True when an AD answer is a simulator's: its version ends in :data:`SIMULATOR_MARK`."""
    return info.version.strip().upper().endswith(SIMULATOR_MARK)
