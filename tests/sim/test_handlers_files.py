"""FA-FH through a real HostLink: the channel's JOB and PNT files and the alarm history."""

from __future__ import annotations

import pytest
from sim_harness import Failure, Harness

from robostar.commands.control import StartJob
from robostar.commands.files import (
    CopyFile,
    DeleteFile,
    DownloadFile,
    FileExists,
    ListFiles,
    ReadAlarmHistory,
    RenameFile,
    UploadFile,
    format_point_line,
)
from robostar.commands.job import ReadJobName, SelectJob
from robostar.commands.motion import Home
from robostar.commands.status import ReadAlarms
from robostar.protocol.fields import FileName
from robostar.protocol.link import UploadReady
from robostar.protocol.packets import Shape
from robostar.sim.alarms import AlarmCode
from robostar.sim.filesystem import DEMO_JOB
from robostar.types import ArmForm, CoordSystem, FileRecord, JobFile, Point, PointFile


def codes(h: Harness) -> list[int]:
    return [a.code for a in h.ok(ReadAlarms())]


def names(h: Harness, channel: int = 1) -> list[str]:
    return [r.name for r in h.ok(ListFiles(channel))]


# -- FA ----------------------------------------------------------------------------------------
def test_fa_downloads_the_demo_job_and_its_points():
    h = Harness()
    assert h.ok(DownloadFile(1, "DEMO.JOB")) == JobFile(DEMO_JOB)
    points = h.ok(DownloadFile(1, "DEMO.PNT"))
    assert points.points[1] == Point((30.0, 60.0, 50.0, 0.0), ArmForm.RIGHT, True)
    assert points.max_point == 3


def test_fa_of_points_in_xy():
    h = Harness()
    points = h.ok(DownloadFile(1, "DEMO.PNT", CoordSystem.XY))
    assert points.points[1].axes == pytest.approx((303.109, 425.0, 50.0, 90.0), abs=1e-3)
    cartesian = h.ok(DownloadFile(2, "DEMO.PNT", CoordSystem.XY))
    assert cartesian.points[2].axes == (300.0, 200.0)


def test_fa_of_a_missing_file_is_refused():
    h = Harness()
    assert "no file NOPE.JOB on channel 1" in h.fail(DownloadFile(1, "NOPE.JOB"))


def test_fa_name_rules_answer_with_the_manuals_flags():
    h = Harness()
    long_name = h.raw(b"\xffFA00" + b"TOOLONG.JOB".rjust(12) + b"0", Shape.MULTI)
    assert isinstance(long_name, Failure) and long_name.flag == 0x32
    mixed = h.raw(b"\xffFA00" + b"Demo.JOB".rjust(12) + b"0", Shape.MULTI)
    assert isinstance(mixed, Failure) and mixed.flag == 0x32
    storage = h.raw(b"\xffFA01" + b"DEMO.JOB".rjust(12) + b"0", Shape.MULTI)
    assert isinstance(storage, Failure) and storage.flag == 0x33


# -- FB ----------------------------------------------------------------------------------------
def test_fb_uploads_a_new_job():
    h = Harness()
    lines = ["MAIN", "IF I100==0 THEN", "EOP"]
    assert h.ok(UploadFile(1, "RS.JOB", 12, lines)) is None
    assert h.ok(DownloadFile(1, "RS.JOB")).lines == tuple(lines)
    assert FileRecord(12, "RS.JOB", 1, 3) in h.ok(ListFiles(1))
    assert h.controller.executions["FB"] == 1


def test_fb_over_an_existing_job_needs_its_job_number():
    h = Harness()
    reason = h.fail(UploadFile(1, "DEMO.JOB", 2, ["MAIN", "EOP"]))
    assert "job number 1, not 2" in reason
    assert codes(h) == [AlarmCode.JOB_NUMBER]
    assert h.ok(DownloadFile(1, "DEMO.JOB")).lines == DEMO_JOB
    h.ok(UploadFile(1, "DEMO.JOB", 1, ["MAIN", "EOP"]))
    assert h.ok(DownloadFile(1, "DEMO.JOB")).lines == ("MAIN", "EOP")


def test_fb_commits_only_on_the_closing_packet():
    h = Harness()
    command = UploadFile(1, "HALF.JOB", 3, ["MAIN", "DELAY 5", "EOP"])
    events = h.host.send_request(command.encode(), command.SHAPE, h.now)
    sent = 0
    for _ in range(20):
        for event in events:
            if isinstance(event, UploadReady) and sent < 2:
                h.host.send_upload_line(command.upload_bodies()[sent], h.now)
                sent += 1
        events, _ = h._pump()
    assert sent == 2
    h.host.abort(h.now)  # RST before the closing 0x34
    h._pump()
    assert not h.ok(FileExists(1, "HALF.JOB"))
    assert h.controller.executions["FB"] == 0


def test_fb_uploads_points():
    h = Harness()
    points = {4: Point((1.0, 2.0, 3.0, 4.0), ArmForm.RIGHT, True), 9: Point((5.0,), used=False)}
    lines = [format_point_line(n, p) for n, p in points.items()]
    h.ok(UploadFile(1, "PTS.PNT", 0, lines))
    assert h.ok(DownloadFile(1, "PTS.PNT")) == PointFile(points)


def test_fb_refuses_a_point_line_that_does_not_parse():
    h = Harness()
    bodies = [b"P0001 not a point\n"]
    _, error = h.exchange_raw(UploadFile(1, "PTS.PNT", 0).encode(), Shape.UPLOAD, bodies=bodies)
    assert error is not None and error.flag == 0x31
    assert "P0001 not a point" in h.kd()
    assert not h.ok(FileExists(1, "PTS.PNT"))


def test_fb_of_the_running_job_is_refused():
    h = Harness()
    h.ok(Home(1))
    h.wait_model(2.1)
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(StartJob(1))
    assert "running job" in h.fail(UploadFile(1, "DEMO.JOB", 1, ["MAIN", "EOP"]))


# -- FC, FD ------------------------------------------------------------------------------------
def test_fc_says_whether_a_file_exists():
    h = Harness()
    assert h.ok(FileExists(1, "DEMO.JOB")) is True
    assert h.ok(FileExists(1, "demo.pnt")) is True
    assert h.ok(FileExists(1, "RS.JOB")) is False


def test_fd_lists_every_file_or_one():
    h = Harness()
    everything = (FileRecord(1, "DEMO.JOB", 1, 8), FileRecord(1, "DEMO.PNT", 1, 3))
    assert h.ok(ListFiles(1)) == everything
    assert h.ok(ListFiles(1, "*.*")) == everything
    assert h.ok(ListFiles(1, "DEMO.PNT")) == everything[1:]
    assert h.ok(ListFiles(1, "NONE.JOB")) == ()


def test_fd_size_is_in_kb_rounded_up_and_steps_count_lines():
    h = Harness()
    lines = ["X" * 98] * 11  # 11 x 99 bytes = 1089 bytes
    h.ok(UploadFile(1, "BIG.JOB", 5, lines))
    assert h.ok(ListFiles(1, "BIG.JOB")) == (FileRecord(5, "BIG.JOB", 2, 11),)


# -- FE, FF, FG --------------------------------------------------------------------------------
def test_fe_deletes_job_files_only():
    h = Harness()
    assert "PNT files cannot be deleted" in h.fail(DeleteFile(1, "DEMO.PNT"))
    h.ok(DeleteFile(1, "DEMO.JOB"))
    assert names(h) == ["DEMO.PNT"]
    assert "no file DEMO.JOB" in h.fail(DeleteFile(1, "DEMO.JOB"))


def test_fe_of_the_selected_job_deselects_it():
    h = Harness()
    h.ok(Home(1))
    h.wait_model(2.1)
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(DeleteFile(1, "DEMO.JOB"))
    assert h.ok(ReadJobName(1)) is None


def test_ff_copies_within_a_channel():
    h = Harness()
    h.ok(CopyFile(1, "DEMO.JOB", 1, "TT.JOB"))
    h.ok(CopyFile(1, "DEMO.PNT", 1, "TT.PNT"))
    assert h.ok(DownloadFile(1, "TT.JOB")).lines == DEMO_JOB
    records = {r.name: r for r in h.ok(ListFiles(1))}
    assert records["TT.JOB"].job_number == 2  # the lowest free number
    assert records["TT.PNT"].job_number == 2


def test_ff_across_channels_is_run_fail():
    h = Harness()
    assert "within one channel" in h.fail(CopyFile(1, "DEMO.JOB", 2, "TT.JOB"))
    assert codes(h) == [AlarmCode.RUN_FAIL]
    assert not h.ok(FileExists(2, "TT.JOB"))


@pytest.mark.parametrize(
    ("source", "target", "text", "alarm"),
    [
        ("NONE.JOB", "TT.JOB", "no file NONE.JOB", True),
        ("DEMO.JOB", "DEMO.JOB", "already exists", False),
        ("DEMO.JOB", "TT.PNT", "not the same kind", False),
    ],
)
def test_ff_refusals(source, target, text, alarm):
    h = Harness()
    assert text in h.fail(CopyFile(1, source, 1, target))
    assert codes(h) == ([AlarmCode.RUN_FAIL] if alarm else [])


def test_fg_renames_and_follows_the_selected_job():
    h = Harness()
    h.ok(Home(1))
    h.wait_model(2.1)
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(RenameFile(1, "DEMO.JOB", "T1.JOB"))
    assert names(h) == ["DEMO.PNT", "T1.JOB"]
    assert h.ok(ReadJobName(1)) == FileName("T1", "JOB")
    h.ok(RenameFile(1, "demo.pnt", "t1.pnt"))
    assert names(h) == ["T1.JOB", "t1.pnt"]


@pytest.mark.parametrize(
    ("source", "target", "text", "alarm"),
    [
        ("NONE.JOB", "T1.JOB", "no file NONE.JOB", True),
        ("DEMO.JOB", "DEMO.PNT", "not the same kind", False),
    ],
)
def test_fg_refusals(source, target, text, alarm):
    h = Harness()
    assert text in h.fail(RenameFile(1, source, target))
    assert codes(h) == ([AlarmCode.RUN_FAIL] if alarm else [])


def test_fg_onto_an_existing_name_is_refused():
    h = Harness()
    h.ok(CopyFile(1, "DEMO.JOB", 1, "TT.JOB"))
    assert "already exists" in h.fail(RenameFile(1, "DEMO.JOB", "TT.JOB"))


# -- FH ----------------------------------------------------------------------------------------
def test_fh_reads_the_history_with_the_work_timer():
    h = Harness(speedup=100.0)
    assert h.ok(ReadAlarmHistory()) == ()
    h.wait_model(3725.0)  # 1 h 2 min 5 s
    h.model.raise_alarm(AlarmCode.TP_EMERGENCY, 9, "pendant")
    h.fail(CopyFile(1, "DEMO.JOB", 2, "TT.JOB"))  # run fail on channel 1
    records = h.ok(ReadAlarmHistory())
    assert [(r.page, r.index, r.code, r.channel) for r in records] == [
        (1, 1, AlarmCode.RUN_FAIL, 1),
        (1, 2, 1153, 9),
    ]
    newest, oldest = records
    assert (oldest.day, oldest.hours, oldest.minutes, oldest.seconds) == (0, 1, 2, 5)
    assert (oldest.text, oldest.detail) == ("T/P Emergency", "pendant")
    assert newest.text == "Run Fail"


def test_a_channel_holds_no_more_files_than_one_fd_answer_lists() -> None:
    """FD's answer is capped at what a channel holds (a JOB and a PNT file per JOB number and
    END): the simulator refuses a new file past it, so its directory always lists whole."""
    from robostar import Client
    from robostar.commands.files import ListFiles
    from robostar.errors import ControllerError
    from robostar.sim.ops_files import MAX_FILES
    from robostar.types import Point

    assert MAX_FILES == ListFiles.MAX_PACKETS - 1 == 402
    points = {1: Point((1.0, 2.0, 3.0, 0.0))}
    with Client("sim://", timeout=1.0) as client:
        held = len(client.list_files(1))
        for i in range(MAX_FILES - held):
            client.upload_points(1, f"P{i:04d}.PNT", points, number=0)
        assert len(client.list_files(1)) == MAX_FILES  # listed whole, under the cap
        with pytest.raises(ControllerError):
            client.upload_points(1, "MORE.PNT", points, number=0)
        client.upload_points(1, "P0000.PNT", points, number=0)  # rewriting one still works
        assert len(client.list_files(1)) == MAX_FILES
