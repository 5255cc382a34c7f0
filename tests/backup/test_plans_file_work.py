"""The backup's plans and its manifest format touch no file themselves: they import no module
that does file work and call no file method; every file operation is the store's, which the
plans ask their client to run (a Blocking effect)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import robostar.backup

PACKAGE = Path(robostar.backup.__file__).parent

FILE_MODULES = frozenset(("shutil", "tempfile", "io", "pathlib", "glob"))
FILE_CALLS = frozenset(
    (
        "open",
        "read_text",
        "read_bytes",
        "write_text",
        "write_bytes",
        "mkdir",
        "rmdir",
        "iterdir",
        "rglob",
        "glob",
        "exists",
        "is_dir",
        "is_file",
        "stat",
        "lstat",
        "chmod",
        "unlink",
        "replace",
        "rename",
        "resolve",
        "rmtree",
        "mkdtemp",
        "listdir",
        "scandir",
    )
)


def file_work(source: str) -> list[str]:
    """The file-work imports and calls of a module's source, as "line: what"."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""]
        elif isinstance(node, ast.Call):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in FILE_CALLS:
                found.append(f"{node.lineno}: {name}()")
            continue
        else:
            continue
        found += [f"{node.lineno}: import {n}" for n in names if n.split(".")[0] in FILE_MODULES]
    return found


@pytest.mark.parametrize("module", ["plans.py", "manifest.py"])
def test_the_module_does_no_file_work(module: str) -> None:
    assert file_work((PACKAGE / module).read_text(encoding="utf-8")) == []


def test_the_check_sees_file_work() -> None:
    assert file_work((PACKAGE / "store.py").read_text(encoding="utf-8"))
    assert file_work("import shutil\n") == ["1: import shutil"]
    assert file_work("from pathlib import Path\n") == ["1: import pathlib"]
    assert file_work("def f(p):\n    return p.read_bytes()\n") == ["2: read_bytes()"]
