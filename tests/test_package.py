"""The package as a user installs it: one version everywhere, ``python -m robostar``, typed."""

from __future__ import annotations

import subprocess
import sys
from importlib import metadata
from pathlib import Path

import robostar


def test_one_version_everywhere() -> None:
    assert robostar.__version__ == metadata.version("robostar")


def test_python_dash_m_robostar_prints_the_version() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "robostar", "--version"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert robostar.__version__ in done.stdout


def test_the_package_is_marked_typed() -> None:
    assert (Path(robostar.__file__).parent / "py.typed").is_file()


def test_metadata_is_complete() -> None:
    meta = metadata.metadata("robostar")
    assert meta["Requires-Python"] == ">=3.11"
    assert meta["License-Expression"] == "MIT"
    classifiers = meta.get_all("Classifier") or []
    assert "Typing :: Typed" in classifiers
    assert any(c.startswith("Programming Language :: Python :: 3.11") for c in classifiers)
