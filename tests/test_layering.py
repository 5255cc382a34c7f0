"""Tests of the import direction: types <- errors <- protocol <- commands <- {client, sim} <- serve
<- cli.

The imports are read with ``ast`` (nothing is imported), so the test also sees imports inside
functions. Packages that do not exist yet (client, sim, cli, transport) are simply not checked.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import pytest

import robostar
from robostar.serve.faces import FACES

SRC = Path(robostar.__file__).parent

LAYER = {
    "types": 0,
    "errors": 1,
    "protocol": 2,
    "commands": 3,
    "client": 4,
    "backup": 4,
    "sim": 4,
    "controller_role": 4,
    "listen": 1,
    "serve": 5,
    "cli": 6,
    "": 6,
}
"""Rank of each part of the package (``""`` is the package root, the public facade, which
re-exports from the top): a part may import only parts of lower or equal rank."""

TRANSPORT_MAY_NOT_IMPORT = frozenset(("protocol", "commands", "client", "cli"))
"""transport is a byte pipe: it knows nothing of the protocol, and the client sits above it."""

CONTROLLER_ROLE_MAY_NOT_IMPORT = frozenset(("sim", "client", "cli", "serve", ""))
"""controller_role is the N1 controller role for the simulator and the line server: it knows
neither."""

SANS_IO_SERVING = frozenset(("robostar.controller_role.session",))
"""The controller-role session is sans-IO like the core (the hosts around it do the I/O)."""

SERVE_MAY_NOT_IMPORT = frozenset(("sim", "cli", ""))
"""The line server owns lines by URL (sim:// included): it never imports the simulator itself."""

BELOW_TRANSPORT = frozenset(("errors", "types", "protocol", "commands"))
"""The sans-IO core and its roots never reach for a transport."""

NO_IO_MODULES = frozenset(
    (
        "socket",
        "threading",
        "time",
        "asyncio",
        "serial",
        "select",
        "selectors",
        "serial_asyncio_fast",
        "multiprocessing",
        "subprocess",
    )
)
"""Modules the sans-IO core may not import: no sockets, ports, threads, processes or clock."""


@dataclass(frozen=True)
class Import:
    module: str  # dotted name of the importing module
    target: str  # dotted name imported
    line: int


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_of(source: str, module: str, *, is_package: bool) -> list[Import]:
    """Every module ``module`` imports (absolute names; relative imports resolved)."""
    package = module if is_package else module.rpartition(".")[0]
    found: list[Import] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [Import(module, alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base_parts = package.split(".")
                base_parts = base_parts[: len(base_parts) - (node.level - 1)]
                base = ".".join(base_parts)
                target = f"{base}.{node.module}" if node.module else base
            else:
                target = node.module or ""
            # A name may be a submodule (``from robostar import client``): count each one.
            found += [Import(module, f"{target}.{a.name}", node.lineno) for a in node.names]
    return found


def all_imports(root: Path) -> list[Import]:
    found: list[Import] = []
    for path in sorted(root.rglob("*.py")):
        name = module_name(path, root)
        found += imports_of(
            path.read_text(encoding="utf-8"), name, is_package=path.name == "__init__.py"
        )
    return found


def part_of(dotted: str) -> str | None:
    """The top-level part of robostar a dotted name belongs to (None outside robostar)."""
    parts = dotted.split(".")
    if parts[0] != "robostar":
        return None
    return parts[1] if len(parts) > 1 else ""


def _face(dotted: str) -> str | None:
    """The face a module belongs to (``robostar.serve.faces.NAME...``), else None."""
    parts = dotted.split(".")
    if len(parts) > 3 and parts[:3] == ["robostar", "serve", "faces"] and parts[3] in FACES:
        return parts[3]
    return None  # the registry (robostar.serve.faces itself: Face, create_face) is no face


def layering_violations(found: list[Import]) -> list[str]:
    problems: list[str] = []
    for imp in found:
        source = part_of(imp.module)
        target = part_of(imp.target)
        where = f"{imp.module}:{imp.line} imports {imp.target}"
        face, other = _face(imp.module), _face(imp.target)
        if face and other and face != other:
            problems.append(f"{where}: a face never depends on another face")
            continue
        if source is None or target is None or source == target:
            continue
        if source == "controller_role" and target in CONTROLLER_ROLE_MAY_NOT_IMPORT:
            problems.append(f"{where}: controller_role knows nothing of {target or 'the facade'}")
        elif (
            source == "controller_role"
            and target == "transport"
            and not imp.target.startswith("robostar.transport.peer")
        ):
            problems.append(
                f"{where}: controller_role takes only the byte-peer interface of transport"
            )
        elif source == "serve" and target in SERVE_MAY_NOT_IMPORT:
            problems.append(f"{where}: serve knows nothing of {target or 'the facade'}")
        elif source == "transport" and target in TRANSPORT_MAY_NOT_IMPORT:
            problems.append(f"{where}: transport knows nothing of the protocol or the client")
        elif source in BELOW_TRANSPORT and target == "transport":
            problems.append(f"{where}: the core may not reach for a transport")
        elif source in LAYER and target in LAYER and LAYER[target] > LAYER[source]:
            problems.append(f"{where}: {source} sits below {target}")
    return problems


def io_violations(found: list[Import]) -> list[str]:
    return [
        f"{imp.module}:{imp.line} imports {imp.target}"
        for imp in found
        if (part_of(imp.module) in ("protocol", "commands") or imp.module in SANS_IO_SERVING)
        and imp.target.split(".")[0] in NO_IO_MODULES
    ]


def test_the_package_is_where_the_test_looks() -> None:
    found = all_imports(SRC)
    modules = {imp.module for imp in found}
    assert "robostar.protocol.link" in modules
    assert "robostar.commands.base" in modules


def test_imports_point_one_way() -> None:
    assert layering_violations(all_imports(SRC)) == []


def test_protocol_and_commands_do_no_io() -> None:
    assert io_violations(all_imports(SRC)) == []


# -- the checker itself must catch what it is meant to catch -----------------------------------
@pytest.mark.parametrize(
    ("module", "source", "is_package"),
    [
        ("robostar.protocol.frame", "from robostar.commands import COMMANDS\n", False),
        ("robostar.types", "from robostar.errors import FieldError\n", False),
        ("robostar.types", "import robostar.protocol.fields\n", False),
        ("robostar.commands.base", "def f():\n    from robostar.client import Client\n", False),
        ("robostar.sim.model", "from ..cli import main\n", False),
        ("robostar.transport", "from ..protocol.frame import STX\n", True),
        ("robostar.transport.tcp", "from robostar.commands.base import Command\n", False),
        ("robostar.transport.tcp", "from robostar import client\n", False),
        ("robostar.protocol.link", "from robostar.transport import BytePeer\n", False),
        ("robostar.commands", "from .. import client\n", True),
        ("robostar.controller_role.session", "from robostar.sim.model import Model\n", False),
        (
            "robostar.controller_role.limits",
            "from robostar.transport.tcp import TcpTransport\n",
            False,
        ),
        ("robostar.controller_role", "from robostar.client import Client\n", True),
        ("robostar.protocol.frame", "import robostar\n", False),
        ("robostar.serve.line", "from robostar.sim import VirtualController\n", False),
        ("robostar.serve.faces.api", "from robostar.serve.faces.n1 import N1Face\n", False),
        ("robostar.client.sync", "from robostar.serve import LineServer\n", False),
    ],
)
def test_the_layering_check_catches_a_wrong_import(
    module: str, source: str, is_package: bool
) -> None:
    found = imports_of(source, module, is_package=is_package)
    assert layering_violations(found), found


@pytest.mark.parametrize(
    ("module", "source", "is_package"),
    [
        ("robostar.commands.base", "from robostar.protocol.fields import Reader\n", False),
        ("robostar.protocol.link", "from .frame import STX\n", False),
        ("robostar.protocol", "from . import frame\n", True),
        ("robostar.cli.main", "from robostar.client import Client\n", False),
        ("robostar.sim.model", "from robostar.commands import COMMANDS\n", False),
        ("robostar.transport.sim", "from robostar.errors import PortError\n", False),
        ("robostar.client.sync", "from robostar.transport import open_url\n", False),
        ("robostar.cli.main", "from robostar import __version__\n", False),
        ("robostar", "from robostar.client import Client\n", True),
        (
            "robostar.sim.listeners",
            "from robostar.controller_role import ControllerSession\n",
            False,
        ),
        ("robostar.serve.faces.n1.host", "from robostar.transport.peer import BytePeer\n", False),
        (
            "robostar.controller_role.session",
            "from robostar.commands import decode_request\n",
            False,
        ),
    ],
)
def test_the_layering_check_passes_a_right_import(
    module: str, source: str, is_package: bool
) -> None:
    assert layering_violations(imports_of(source, module, is_package=is_package)) == []


@pytest.mark.parametrize(
    "source",
    [
        "import time\n",
        "from time import monotonic\n",
        "import socket\n",
        "def f():\n    import threading\n",
        "from asyncio import sleep\n",
        "import serial.tools.list_ports\n",
        "import select\n",
    ],
)
def test_the_io_check_catches_io_in_the_core(source: str) -> None:
    found = imports_of(source, "robostar.protocol.link", is_package=False)
    assert io_violations(found)
    found = imports_of(source, "robostar.commands.files", is_package=False)
    assert io_violations(found)
    assert io_violations(imports_of(source, "robostar.client.sync", is_package=False)) == []
