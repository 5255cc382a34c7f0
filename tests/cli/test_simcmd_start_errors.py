"""`robostar sim` refusing to start: a bad state file is named with its key and value and gets
a hint about the file; an unknown dialect gets a hint that lists the dialects. Neither says
"Nothing was sent" or points at --help, which fit a command's arguments, not these."""

from __future__ import annotations

from pathlib import Path

import pytest

from robostar.sim.dialects import DIALECTS

from .conftest import Run


@pytest.mark.parametrize(
    ("content", "says"),
    [
        ('{"format": 1, "work_timer": NaN}', "work_timer: NaN is not a number"),
        ('{"format": 1, "floats": [[3, Infinity]]}', "floats[0][1]: Infinity is not a number"),
    ],
)
def test_a_state_file_holding_nan_names_the_file_and_the_key(
    run: Run, tmp_path: Path, content: str, says: str
) -> None:
    (tmp_path / "state.json").write_text(content, encoding="utf-8")
    result = run("sim", "--state", str(tmp_path), "--listen", "127.0.0.1:0", port=None)
    assert result.exit_code == 2
    assert f"{tmp_path / 'state.json'}: {says}" in result.stderr
    assert "remove it to start afresh" in result.stderr
    assert "Nothing was sent" not in result.stderr and "--help" not in result.stderr


def test_an_unknown_dialect_lists_the_dialects(run: Run) -> None:
    result = run("sim", "--dialect", "nope", port=None)
    assert result.exit_code == 2
    assert "Nothing was sent" not in result.stderr
    assert all(name in result.stderr for name in DIALECTS)
    assert "robostar sim --dialect manual" in result.stderr
