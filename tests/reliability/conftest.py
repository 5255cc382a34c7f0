"""Reliability tests: make the repository's ``reliability`` harness importable, add ``--full``.

The harness (fuzz targets, fault matrix, soak) lives in ``reliability/`` at the repository root,
where ``reliability/run.py`` runs its long versions; these tests run CI-sized slices of it.
``pytest tests/reliability --full`` runs the whole fault matrix instead of the CI slice.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--full",
        action="store_true",
        default=False,
        help="reliability: run the full fault matrix, not the CI slice",
    )


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "full: the long reliability runs (need --full)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("--full"):
        return
    skip = pytest.mark.skip(reason="long reliability run: pass --full")
    for item in items:
        if "full" in item.keywords:
            item.add_marker(skip)
