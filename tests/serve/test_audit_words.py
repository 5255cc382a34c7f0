"""The audit log in words: commands described with names, numbers and units (no Python reprs),
a file write as name, size and hash (not its text), and a jog's keepalives not written while
its start and stop are."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from robostar.commands.control import EmergencyStop, SetSpeed, StartJob
from robostar.commands.files import UploadFile
from robostar.commands.io import SetOutput
from robostar.commands.job import SelectJob, Servo, SetJobMode
from robostar.commands.motion import Home, JogContinue, JogStart, JogStop, MoveBy
from robostar.commands.variables import WriteGlobalFloat, WriteGlobalInt
from robostar.serve.audit import AuditLog
from robostar.serve.audit_words import describe, text_hash
from robostar.types import CoordSystem, JobMode, JogDirection, MotionType


@pytest.mark.parametrize(
    ("command", "words"),
    [
        (
            JogStart(1, 2, JogDirection.PLUS, MotionType.JOINT),
            "JogStart(channel=1, axis=2, direction=PLUS, motion=JOINT)",
        ),
        (JogStop(1), "JogStop(channel=1)"),
        (SetSpeed(2, 375), "SetSpeed(channel=2, speed=37.5 %)"),
        (Servo(1, True), "Servo(channel=1, on=True)"),
        (SelectJob(1, "DEMO.JOB"), "SelectJob(channel=1, file=DEMO.JOB)"),
        (SetJobMode(1, JobMode.STEP), "SetJobMode(channel=1, mode=STEP)"),
        (StartJob(1), "StartJob(channel=1)"),
        (Home(2), "Home(channel=2)"),
        (EmergencyStop(), "EmergencyStop()"),
        (SetOutput(0, 5, False), "SetOutput(port=0, contact=5, on=False)"),
        (WriteGlobalInt(3, 4321), "WriteGlobalInt(index=3, value=4321)"),
        (WriteGlobalFloat(2, 12.5), "WriteGlobalFloat(index=2, value=12.5)"),
        (
            MoveBy(1, MotionType.JOINT, CoordSystem.ANGLE, (0.0, 0.0, 1.0, 0.0)),
            "MoveBy(channel=1, motion=JOINT, coords=ANGLE, delta=(0, 0, +1.000, 0) °/mm)",
        ),
    ],
)
def test_commands_in_words(command: object, words: str) -> None:
    text = describe(command)  # type: ignore[arg-type]
    assert text == words
    assert "<" not in text and "FileName(" not in text


def test_a_file_write_is_its_name_size_and_hash() -> None:
    lines = ("MAIN", "MOVJ P0001", "EOP")
    text = describe(UploadFile(1, "DEMO.JOB", 1, lines))
    digest = text_hash(lines)[:16]
    assert text == (
        f"UploadFile(channel=1, file=DEMO.JOB, job_number=1: 3 lines, 20 bytes, sha256 {digest})"
    )
    assert "MOVJ" not in text


def test_keepalives_that_went_through_are_not_written(tmp_path: Path) -> None:
    log = AuditLog(tmp_path / "audit.jsonl")
    for command, outcome in (
        (JogStart(1, 1, JogDirection.MINUS, MotionType.LINEAR), "ok"),
        (JogContinue(1), "ok"),
        (JogContinue(1), "ok"),
        (JogContinue(1), "error: ReplyTimeoutError: no answer"),
        (JogStop(1), "ok"),
    ):
        log.write(line="cell1", who="olga", face="web", what=describe(command), outcome=outcome)
    log.close()
    entries = [json.loads(t) for t in (tmp_path / "audit.jsonl").read_text().splitlines()]
    assert [e["what"] for e in entries] == [
        "JogStart(channel=1, axis=1, direction=MINUS, motion=LINEAR)",
        "jog keepalive: channel 1",  # a failed keepalive is worth a line
        "JogStop(channel=1)",
    ]
