"""`robostar -c 2 restore DIR` restores channel 2 only, as every other command honours the
global --channel; a global channel that disagrees with restore's own is refused."""

from __future__ import annotations

from pathlib import Path

from .conftest import Run, SimLine


def _edited_on_both_channels(on: Run, tmp_path: Path) -> Path:
    folder = tmp_path / "bk"
    assert on("backup", str(folder)).exit_code == 0
    job = tmp_path / "new1.job"
    job.write_text("MAIN\nWAIT 5\nEOP\n")
    for channel in ("1", "2"):
        assert on("-c", channel, "files", "put", str(job), "--name", "DEMO.JOB").exit_code == 0
    return folder


def test_the_global_channel_chooses_what_is_restored(
    on: Run, sim_line: SimLine, tmp_path: Path
) -> None:
    folder = _edited_on_both_channels(on, tmp_path)
    result = on("-c", "2", "restore", str(folder), "--yes")
    assert result.exit_code == 0, result.output
    assert "ch2/DEMO.JOB" in result.stdout and "ch1/" not in result.stdout
    assert sim_line.jobs(1)["DEMO.JOB"] == ["MAIN", "WAIT 5", "EOP"]  # channel 1 left alone
    assert sim_line.jobs(2)["DEMO.JOB"] != ["MAIN", "WAIT 5", "EOP"]


def test_a_global_channel_that_disagrees_is_refused(
    on: Run, sim_line: SimLine, tmp_path: Path
) -> None:
    folder = _edited_on_both_channels(on, tmp_path)
    before = (sim_line.jobs(1), sim_line.jobs(2))
    result = on("-c", "2", "restore", str(folder), "--yes", "--channel", "1")
    assert result.exit_code == 2, result.output
    assert "disagree" in result.stderr
    assert (sim_line.jobs(1), sim_line.jobs(2)) == before
    agreed = on("-c", "2", "restore", str(folder), "--yes", "-c", "1", "-c", "2")
    assert agreed.exit_code == 0, agreed.output


def test_without_a_channel_every_channel_is_restored(
    on: Run, sim_line: SimLine, tmp_path: Path
) -> None:
    folder = _edited_on_both_channels(on, tmp_path)
    result = on("restore", str(folder), "--yes")
    assert result.exit_code == 0, result.output
    assert sim_line.jobs(1)["DEMO.JOB"] == sim_line.jobs(2)["DEMO.JOB"] != ["MAIN", "WAIT 5", "EOP"]
