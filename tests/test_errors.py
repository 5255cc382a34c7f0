"""The exception tree: its shape, the standard bases, messages, error_for_flag, and that
errors.py's drawing lists every exception class of robostar under the module to catch it from."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
from types import ModuleType

import pytest

import robostar
import robostar.errors as errors
from robostar.errors import (
    AlarmRaisedError,
    AnswerTooLongError,
    ControlHeldError,
    ControllerError,
    FieldError,
    FrameError,
    FunctionFailedError,
    JogInterruptedError,
    LineError,
    LinkResetError,
    LinkRuleError,
    MalformedAnswerError,
    NakLimitError,
    NotSupportedError,
    OutcomeUnknownError,
    PacketTooLongError,
    PortError,
    ProtocolError,
    RejectedError,
    ReplyTimeoutError,
    RobostarError,
    UploadIncompleteError,
    UsageError,
    WaitError,
    WaitTimeoutError,
    error_for_flag,
)

EXPECTED_PARENT: dict[type[Exception], type[Exception]] = {
    UsageError: RobostarError,
    FieldError: UsageError,
    PacketTooLongError: FieldError,
    ProtocolError: RobostarError,
    FrameError: ProtocolError,
    LinkRuleError: ProtocolError,
    MalformedAnswerError: ProtocolError,
    AnswerTooLongError: ProtocolError,
    ControllerError: RobostarError,
    RejectedError: ControllerError,
    FunctionFailedError: ControllerError,
    ControlHeldError: FunctionFailedError,
    NotSupportedError: ControllerError,
    LineError: RobostarError,
    ReplyTimeoutError: LineError,
    OutcomeUnknownError: LineError,
    NakLimitError: LineError,
    LinkResetError: LineError,
    UploadIncompleteError: LineError,
    PortError: LineError,
    WaitError: RobostarError,
    WaitTimeoutError: WaitError,
    AlarmRaisedError: WaitError,
    JogInterruptedError: RobostarError,
}


def _exception_classes() -> dict[str, type[BaseException]]:
    return {
        name: obj
        for name, obj in vars(errors).items()
        if inspect.isclass(obj) and issubclass(obj, BaseException)
    }


def _drawn_tree() -> dict[str, str]:
    """Child -> parent as the module docstring draws the tree."""
    doc = errors.__doc__ or ""
    parents: dict[str, str] = {}
    stack: list[tuple[int, str]] = []
    for line in doc.splitlines():
        root = re.fullmatch(r"\s*(RobostarError)\s*", line)
        if root:
            stack = [(-1, root.group(1))]
            continue
        match = re.match(r"^(\s*(?:│\s*)*)[├└]── (\w+)", line)
        if not match:
            continue
        depth = len(match.group(1))
        name = match.group(2)
        while stack and stack[-1][0] >= depth:
            stack.pop()
        parents[name] = stack[-1][1]
        stack.append((depth, name))
    return parents


@pytest.mark.parametrize(
    ("child", "parent"), list(EXPECTED_PARENT.items()), ids=lambda c: c.__name__
)
def test_each_error_sits_under_its_parent(child: type[Exception], parent: type[Exception]) -> None:
    assert issubclass(child, parent)
    assert issubclass(child, RobostarError)


def test_every_exception_of_the_module_is_in_the_tree() -> None:
    classes = _exception_classes()
    assert set(classes) == {c.__name__ for c in EXPECTED_PARENT} | {"RobostarError"}
    assert set(errors.__all__) == set(classes) | {"error_for_flag"}


def test_the_docstring_draws_the_real_tree() -> None:
    drawn = _drawn_tree()
    assert drawn == {child.__name__: parent.__name__ for child, parent in EXPECTED_PARENT.items()}
    for child, parent in EXPECTED_PARENT.items():
        assert parent in child.__bases__, f"{child.__name__} is drawn under {parent.__name__}"


def test_branches_do_not_overlap() -> None:
    branches = (UsageError, ProtocolError, ControllerError, LineError, WaitError)
    for a in branches:
        for b in branches:
            if a is not b:
                assert not issubclass(a, b)


def test_standard_bases_so_plain_except_clauses_work() -> None:
    assert issubclass(ReplyTimeoutError, TimeoutError)
    assert issubclass(UsageError, ValueError)
    assert issubclass(FieldError, ValueError)
    assert issubclass(PortError, OSError)
    assert issubclass(WaitTimeoutError, TimeoutError)
    with pytest.raises(TimeoutError):
        raise ReplyTimeoutError("AA", 2.0)
    with pytest.raises(ValueError):
        raise FieldError("CB", "speed", "1001 is out of range 0..1000")
    with pytest.raises(OSError):
        raise PortError("cannot open the port")
    assert not issubclass(ReplyTimeoutError, ValueError)
    assert not issubclass(ControllerError, ValueError)


def test_field_error_names_command_field_and_flag() -> None:
    error = FieldError("CB", "speed", "1001 is out of range 0..1000")
    assert (error.command, error.field, error.flag) == ("CB", "speed", 0x31)
    assert str(error) == "CB speed: 1001 is out of range 0..1000"
    bare = FieldError("", "packet", "too long", flag=0x32)
    assert str(bare) == "packet: too long"
    assert bare.flag == 0x32


def test_link_rule_error_names_role_state_and_event() -> None:
    error = LinkRuleError("host", "WAIT_MORE", "END packet", "single exchange")
    assert (error.role, error.state, error.event) == ("host", "WAIT_MORE", "END packet")
    assert str(error) == "host link in state WAIT_MORE cannot take END packet: single exchange"
    assert str(LinkRuleError("controller", "LISTEN", "TIMEOUT")) == (
        "controller link in state LISTEN cannot take TIMEOUT"
    )


def test_line_errors_carry_the_command() -> None:
    timeout = ReplyTimeoutError("AC", 2.0, "after 3 NAKs")
    assert (timeout.command, timeout.timeout) == ("AC", 2.0)
    assert str(timeout) == "AC: no answer within 2 s (after 3 NAKs)"
    unknown = OutcomeUnknownError("BA")
    assert unknown.command == "BA"
    assert "may or may not" in str(unknown)
    naks = NakLimitError("FA", 4)
    assert (naks.command, naks.naks) == ("FA", 4)
    assert "4 times" in str(naks)
    reset = LinkResetError("CC")
    assert str(reset) == "CC: exchange aborted: RST received"
    malformed = MalformedAnswerError("AA", "3 status bytes expected", b"0\x80")
    assert malformed.command == "AA"
    assert malformed.raw == b"0\x80"
    assert "raw" in str(malformed)


@pytest.mark.parametrize(
    ("flag", "cls"),
    [(0x31, RejectedError), (0x32, FunctionFailedError), (0x33, NotSupportedError)],
)
def test_error_for_flag_maps_each_error_flag(flag: int, cls: type[ControllerError]) -> None:
    error = error_for_flag(flag, "CC", "Origin not done")
    assert type(error) is cls
    assert error.flag == flag
    assert (error.command, error.reason) == ("CC", "Origin not done")
    assert str(error).startswith("CC: ")
    assert f"0x{flag:02X}" in str(error)
    assert str(error).endswith(": Origin not done")


def test_error_for_flag_without_a_reason() -> None:
    error = error_for_flag(0x33, "CX")
    assert error.reason is None
    assert str(error) == "CX: not supported by this controller (flag 0x33)"


@pytest.mark.parametrize("flag", [0x00, 0x30, 0x34, 0x35, 0xFF])
def test_error_for_flag_refuses_flags_that_are_not_errors(flag: int) -> None:
    with pytest.raises(ValueError, match=f"0x{flag:02X}"):
        error_for_flag(flag, "AA")


# The errors of the packages: errors.py's drawing lists each under the module to catch it from.

_PACKAGE_ENTRY = re.compile(r"^ {6}(\w+) \(([\w., ]+)\)\s")
_PACKAGE_HEADING = re.compile(r"^ {4}(robostar(?:\.\w+)+)\b")


def _drawn_package_errors() -> dict[tuple[str, str], tuple[str, ...]]:
    """(module, class name) -> drawn bases, from the docstring's package lists."""
    drawn: dict[tuple[str, str], tuple[str, ...]] = {}
    module = ""
    for line in (errors.__doc__ or "").splitlines():
        heading = _PACKAGE_HEADING.match(line)
        if heading:
            module = heading.group(1)
            continue
        entry = _PACKAGE_ENTRY.match(line)
        if entry and module:
            bases = tuple(base.strip() for base in entry.group(2).split(","))
            drawn[(module, entry.group(1))] = bases
    return drawn


def _base_name(base: type) -> str:
    """A base as the drawing writes it: bare for robostar's and builtins, else ``package.Name``."""
    package = base.__module__.split(".")[0]
    if package in ("robostar", "builtins"):
        return base.__name__
    return f"{package}.{base.__name__}"


def _import_if_installed(name: str) -> ModuleType | None:
    """The module, or None when it needs an optional extra that is not installed."""
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as missing:
        if (missing.name or "robostar").split(".")[0] == "robostar":
            raise
        return None


def _modules_of_the_package() -> list[ModuleType]:
    """Every module of robostar (``__main__`` modules run on import, so they are left out)."""
    modules = []
    for info in pkgutil.walk_packages(robostar.__path__, "robostar.", onerror=lambda _: None):
        if info.name.rsplit(".", 1)[-1] == "__main__":
            continue
        module = _import_if_installed(info.name)
        if module is not None:
            modules.append(module)
    return modules


def _defined_exception_classes() -> dict[str, type[BaseException]]:
    """``module.Name`` -> class, for every exception class defined anywhere in robostar."""
    found: dict[str, type[BaseException]] = {}
    for module in _modules_of_the_package():
        for obj in vars(module).values():
            if (
                inspect.isclass(obj)
                and issubclass(obj, BaseException)
                and obj.__module__ == module.__name__
            ):
                found[f"{obj.__module__}.{obj.__qualname__}"] = obj
    return found


def test_the_drawing_lists_every_exception_class_of_the_package() -> None:
    tree = {f"robostar.errors.{name}" for name in _exception_classes()}
    drawn = _drawn_package_errors()
    listed: set[type[BaseException]] = set()
    for module, name in drawn:
        imported = _import_if_installed(module)
        if imported is None:  # an optional extra this install lacks
            continue
        cls = getattr(imported, name, None)
        assert inspect.isclass(cls), f"{module}.{name} is drawn but cannot be caught from there"
        listed.add(cls)
    missing = {
        where
        for where, cls in _defined_exception_classes().items()
        if where not in tree and cls not in listed
    }
    assert not missing, f"errors.py's drawing does not list {sorted(missing)}"


def test_the_package_errors_are_drawn_with_their_bases() -> None:
    drawn = _drawn_package_errors()
    assert drawn, "the drawing's package lists are not found"
    for (module, name), bases in drawn.items():
        imported = _import_if_installed(module)
        if imported is None:  # an optional extra this install lacks
            continue
        cls = getattr(imported, name)
        assert bases == tuple(_base_name(base) for base in cls.__bases__), f"{module}.{name}"


def test_the_line_server_errors_are_caught_from_robostar_serve() -> None:
    serve = importlib.import_module("robostar.serve")
    for module, name in _drawn_package_errors():
        if module == "robostar.serve":
            assert name in serve.__all__
