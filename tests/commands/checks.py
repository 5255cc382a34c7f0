"""The checks every command family's tests make (each test module names its own commands):
a request that decodes to itself, by its class and through the registry, and the class
attributes the client and the line server rely on."""

from __future__ import annotations

from typing import Any

from robostar.commands import Command, decode_request


def assert_decodes_to(command: Command[Any], data: bytes) -> None:
    """``data`` decodes to ``command`` by its class and by :func:`decode_request`."""
    assert type(command).decode(data) == command
    assert decode_request(data) == command


def assert_round_trip(command: Command[Any]) -> None:
    """``command``'s request decodes back to it."""
    assert_decodes_to(command, command.encode())


def assert_class_attributes(
    cls: type[Command[Any]], *, changes_state: bool, dummy: bool = False
) -> None:
    """Whether it changes state and answers a dummy, and a docstring that opens with its code."""
    assert cls.CHANGES_STATE is changes_state
    assert cls.ANSWER_DUMMY is dummy
    assert (cls.__doc__ or "").startswith(f"{cls.CODE}: ")
