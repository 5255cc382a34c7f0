"""Tests are found from the code: each test file is named ``test_<module>[_<scenario>].py`` after
a module of the package its folder tests, and opens with a docstring that says what it guards,
never how a defect was found (that history belongs in CHANGELOG.md and docs/reliability.md).

The folders checked are listed once, in ``FOLDERS``; widen it as more folders are filed.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import re
from pathlib import Path

import pytest

TESTS = Path(__file__).parent

FOLDERS: dict[str, str | tuple[str, ...] | None] = {
    "backup": "robostar.backup",
    "cli": "robostar.cli",
    "client": ("robostar.client", "robostar.transport"),
    "commands": "robostar.commands",
    "controller_role": "robostar.controller_role",
    "protocol": "robostar.protocol",
    "serve": "robostar.serve",
    "serve/faces": "robostar.serve.faces",
    "serve/faces/n1": "robostar.serve.faces.n1",
    "serve_modbus": "robostar.serve.faces.modbus",
    "serve_mqtt": "robostar.serve.faces.mqtt",
    "serve_opcua": "robostar.serve.faces.opcua",
    "serve_web": "robostar.serve.faces.web",
    "sim": "robostar.sim",
    # Folders of whole-system suites, named after what they exercise rather than one package:
    "api": None,
    "bench": None,
    "dialects": None,
    "plugin": None,
    "reliability": None,
}
"""Test folder -> the package (or packages) whose modules its files are named after (None: a suite
folder whose files need only the docstring rule)."""

IN_FLUX = ("sim/test_journal*", "serve/test_lease*", "reliability/test_history*")
"""Files being rewritten elsewhere right now: checked once they land."""

SCENARIOS = {
    "commands/test_exact_values.py": "values finer than a field's resolution, across commands",
    "serve_opcua/test_every_face_at_once.py": "one line server serving every face at once",
}
"""Files of a folder whose scenario spans the package's modules, with what they cover."""

PROVENANCE = re.compile(r"\breview|found by|\bfinding|\(F\d+\b", re.IGNORECASE)
"""Words that tell where a case came from instead of what it guards."""


def _files(folder: str) -> list[Path]:
    """The folder's Python files, its subfolders' excluded (they are folders of their own)."""
    skipped = {path for pattern in IN_FLUX for path in TESTS.glob(pattern)}
    return sorted(
        path
        for path in (TESTS / folder).glob("*.py")
        if path.name != "__init__.py" and path not in skipped
    )


def _test_files() -> list[Path]:
    return [path for folder in FOLDERS for path in _files(folder) if path.name.startswith("test_")]


def _module_names(package: str) -> set[str]:
    """The modules and subpackages of a package, and the package's own name (for its
    ``__init__``)."""
    imported = importlib.import_module(package)
    names = {info.name for info in pkgutil.iter_modules(imported.__path__)}
    return names | {package.rsplit(".", 1)[-1]}


def _ids(paths: list[Path]) -> list[str]:
    return [path.relative_to(TESTS).as_posix() for path in paths]


def _header(path: Path) -> str | None:
    return ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))


@pytest.mark.parametrize(
    "path",
    [p for f in FOLDERS for p in _files(f)],
    ids=_ids([p for f in FOLDERS for p in _files(f)]),
)
def test_each_file_opens_with_what_it_guards(path: Path) -> None:
    header = _header(path)
    assert header, "the file does not open with a docstring saying what it guards"
    told = PROVENANCE.search(header)
    assert not told, (
        f"the header tells where a case came from ({told.group(0)!r}); say what it guards and "
        "put the history in CHANGELOG.md or docs/reliability.md"
    )


@pytest.mark.parametrize("path", _test_files(), ids=_ids(_test_files()))
def test_each_file_is_named_after_a_module_of_its_package(path: Path) -> None:
    folder = path.parent.relative_to(TESTS).as_posix()
    packages = FOLDERS[folder]
    if packages is None or path.relative_to(TESTS).as_posix() in SCENARIOS:
        return
    if isinstance(packages, str):
        packages = (packages,)
    stem = path.stem.removeprefix("test_")
    modules = set().union(*(_module_names(package) for package in packages))
    assert any(stem == name or stem.startswith(f"{name}_") for name in modules), (
        f"{path.name} names no module of {', '.join(packages)} (test_<module>[_<scenario>].py; "
        f"modules: {', '.join(sorted(modules))})"
    )


def test_the_scenario_files_exist() -> None:
    for name in SCENARIOS:
        assert (TESTS / name).is_file(), f"{name} is listed as a scenario but does not exist"


def test_the_checks_find_provenance_and_a_missing_header(tmp_path: Path) -> None:
    told = tmp_path / "test_told.py"
    told.write_text('"""Refusals (found by review 13)."""\n', encoding="utf-8")
    bare = tmp_path / "test_bare.py"
    bare.write_text("import pytest\n", encoding="utf-8")
    header = _header(told)
    assert header is not None and PROVENANCE.search(header)
    assert _header(bare) is None
    assert not PROVENANCE.search("a preview before the restore")
    assert PROVENANCE.search("Retained command messages (F1): ...")
