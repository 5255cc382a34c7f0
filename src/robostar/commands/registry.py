"""The registry: two letters to the command class(es), and request decoding for the controller."""

from __future__ import annotations

from robostar.commands import control, files, io, job, motion, status, system, variables
from robostar.commands.base import Command
from robostar.errors import FieldError

__all__ = ["COMMANDS", "all_commands", "command_classes", "decode_request"]

_MODULES = (status, motion, control, job, files, io, variables, system)


def _collect() -> dict[str, tuple[type[Command[object]], ...]]:
    table: dict[str, list[type[Command[object]]]] = {}
    for module in _MODULES:
        for name in module.__all__:
            obj = getattr(module, name)
            if isinstance(obj, type) and issubclass(obj, Command) and hasattr(obj, "CODE"):
                table.setdefault(obj.CODE, []).append(obj)
    return {code: tuple(classes) for code, classes in sorted(table.items())}


COMMANDS: dict[str, tuple[type[Command[object]], ...]] = _collect()
"""Code -> command classes; GR and GW have three variants each (point, integer, float)."""


def command_classes(code: str) -> tuple[type[Command[object]], ...]:
    """The classes for a two-letter code; KeyError if the manual has no such command."""
    return COMMANDS[code.upper()]


def all_commands() -> list[type[Command[object]]]:
    """Every command class, in code order."""
    return [cls for classes in COMMANDS.values() for cls in classes]


def decode_request(data: bytes) -> Command[object]:
    """Decode a request packet's data (``FF G1 G2 params``) into its command (controller side).

    Raises FieldError (with the flag a controller answers) when the code is unknown or a field
    is bad.
    """
    if len(data) < 3 or data[0] != 0xFF:
        raise FieldError("", "header", f"{data[:3]!r} is not FF G1 G2")
    code = data[1:3].decode("ascii", "replace")
    classes = COMMANDS.get(code)
    if not classes:
        raise FieldError(code, "command", f"{code!r} is not a command of the protocol")
    params = data[3:]
    for cls in classes:
        if cls.matches(params):
            return cls.decode(data)
    raise FieldError(code, "type", f"no variant of {code} takes {params[:1]!r}")
