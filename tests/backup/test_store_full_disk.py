"""A backup that cannot be written on this computer (a full disk) stops with "cannot write
the backup", exit code 2, not a cable fault; the previous backup, or the previous
generations, are intact and no temporary folder is left."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

from robostar.client import Client

_FULL_DISK = textwrap.dedent(
    """
    import resource, signal, sys
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (64, 64))
    from robostar.cli.app import main
    main(sys.argv[1:])
    """
)


def _backup_on_a_full_disk(*args: str) -> tuple[int, str]:
    """`robostar --port sim:// backup ARGS` in a process whose disk is full: its exit code and
    its stderr on one line."""
    env = {k: v for k, v in os.environ.items() if k != "ROBOSTAR_PORT"}
    done = subprocess.run(
        [sys.executable, "-c", _FULL_DISK, "--port", "sim://", "backup", *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    return done.returncode, " ".join(done.stderr.split())


def test_a_backup_that_cannot_be_written_is_not_called_a_cable_fault(tmp_path: Path) -> None:
    folder = tmp_path / "bk"
    with Client("sim://?speedup=50") as client:
        client.backup(folder)
    before = {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    code, said = _backup_on_a_full_disk(str(folder))
    assert code == 2, said
    assert f"cannot write the backup at '{folder}'" in said.lower()
    assert "the previous backup is intact" in said
    assert "cable" not in said and "port failed" not in said.lower()
    after = {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    assert after == before
    assert [p.name for p in tmp_path.iterdir()] == ["bk"]  # no temporary folder left

    generations = tmp_path / "gens"
    with Client("sim://?speedup=50") as client:
        client.backup(generations, keep=2)
    (first,) = list(generations.iterdir())
    code, said = _backup_on_a_full_disk(str(generations), "--keep", "2")
    assert code == 2, said
    assert "the previous backups in the folder are intact" in said
    assert list(generations.iterdir()) == [first]
