"""`robostar decode`: captures in every format, annotated frame by frame."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from click.testing import Result
from hypothesis import given, settings
from hypothesis import strategies as st

from robostar.cli.annotate import Chunk, Direction, annotate
from robostar.cli.captures import CaptureFormat, detect_format, parse_capture, parse_hexdump
from robostar.commands.status import ReadAlarms, ReadPosition, ReadStatus
from robostar.protocol.frame import ACK, encode_packet
from robostar.types import Alarm, ChannelStatus, Position, PositionKind

Run = Callable[..., Result]
AsJson = Callable[[Result], Any]
ACK_BYTE = bytes((ACK,))
STATUS = (ChannelStatus(servo_on=True, origin=True), ChannelStatus(), ChannelStatus(alarm=True))


def frames_of(command, result) -> tuple[bytes, list[bytes]]:
    request = encode_packet(command.encode())
    answers = [encode_packet(p) for p in command.encode_answer(result)]
    return request, answers


def hexline(prefix: str, data: bytes) -> str:
    return f"{prefix} {data.hex(' ')}"


def status_dump() -> str:
    request, (answer,) = frames_of(ReadStatus(), STATUS)
    return "\n".join([hexline(">", request), hexline("<", answer), hexline(">", ACK_BYTE)])


def test_hex_dump_with_directions_decodes_the_answer_by_its_request(
    run: Run, as_json: AsJson
) -> None:
    data = as_json(run("--json", "decode", "--hex", status_dump(), port=None))
    kinds = [(f["kind"], f["direction"], f["command"]) for f in data["frames"]]
    assert kinds == [
        ("request", "to_controller", "AA"),
        ("answer", "to_host", "AA"),
        ("ack", "to_controller", "AA"),
    ]
    answer = data["frames"][1]
    assert answer["flag"] == "OK"
    assert answer["lrc"] == "ok"
    assert answer["fields"]["result"][0]["servo_on"] is True
    assert answer["fields"]["result"][2]["alarm"] is True
    assert answer["fields"]["result"][1]["servo_on"] is False


def test_request_fields_are_named(run: Run, as_json: AsJson) -> None:
    request = encode_packet(ReadPosition(2, PositionKind.PULSE).encode())
    data = as_json(run("--json", "decode", "--hex", request.hex(), port=None))
    (frame,) = data["frames"]
    assert frame["name"] == "ReadPosition"
    assert frame["fields"] == {"channel": 2, "kind": "pulse"}
    assert frame["inferred"] is True


def test_bad_lrc_is_reported_with_the_expected_value(run: Run, as_json: AsJson) -> None:
    good = encode_packet(ReadStatus().encode())
    bad = good[:-1] + bytes((good[-1] ^ 0x55,))
    data = as_json(run("--json", "decode", "--hex", bad.hex(" "), port=None))
    (frame,) = data["frames"]
    assert frame["kind"] == "corrupt"
    assert frame["lrc"] == f"bad: got 0x{bad[-1]:02X}, want 0x{good[-1]:02X}"
    assert frame["command"] == "AA"


def test_multi_packet_answer_is_decoded_at_its_end() -> None:
    alarms = (Alarm(1153, "T/P Emergency"), Alarm(1104, "Servo Not Redy"))
    request, answers = frames_of(ReadAlarms(), alarms)
    chunks = [Chunk(request, Direction.TO_CONTROLLER)]
    for answer in answers:
        chunks += [Chunk(answer, Direction.TO_HOST), Chunk(ACK_BYTE, Direction.TO_CONTROLLER)]
    frames = annotate(chunks)
    answers_seen = [f for f in frames if f.kind == "answer"]
    assert [f.flag for f in answers_seen] == ["OK", "OK", "END"]
    assert "result" not in answers_seen[0].fields
    assert answers_seen[-1].fields["result"] == [
        {"code": 1153, "text": "T/P Emergency"},
        {"code": 1104, "text": "Servo Not Redy"},
    ]


def test_error_flag_and_resent_answer_are_explained() -> None:
    request = encode_packet(ReadPosition(1).encode())
    refused = encode_packet(b"\x32")
    frames = annotate(
        [
            Chunk(request, Direction.TO_CONTROLLER),
            Chunk(refused, Direction.TO_HOST),
            Chunk(refused, Direction.TO_HOST),
        ]
    )
    assert frames[1].flag == "FAILED"
    assert "KD tells why" in frames[1].note
    assert "sent again" in frames[2].note


def test_direction_is_inferred_in_an_unmarked_raw_capture(
    tmp_path: Path, run: Run, as_json: AsJson
) -> None:
    request, (answer,) = frames_of(ReadPosition(1), Position(PositionKind.XY, (1.0, -2.5)))
    capture = tmp_path / "line.bin"
    capture.write_bytes(request + answer + ACK_BYTE + b"\x55\x55")
    assert detect_format(capture.read_bytes()) is CaptureFormat.RAW
    data = as_json(run("--json", "decode", str(capture), port=None))
    frames = data["frames"]
    assert [f["direction"] for f in frames[:3]] == ["to_controller", "to_host", "to_controller"]
    assert frames[1]["fields"]["result"] == {"kind": "xy", "axes": [1.0, -2.5], "arm": "none"}
    assert frames[-1]["kind"] == "noise"
    assert "2 byte(s)" in frames[-1]["note"]


def test_trace_file_gives_directions_and_times(tmp_path: Path, run: Run, as_json: AsJson) -> None:
    request, (answer,) = frames_of(ReadStatus(), STATUS)
    lines = [
        {"time": 0.5, "direction": "tx", "hex": request.hex(" ")},
        {"time": 0.52, "direction": "rx", "hex": answer.hex(" ")},
        {"time": 0.53, "direction": "tx", "hex": ACK_BYTE.hex()},
    ]
    trace = tmp_path / "trace.jsonl"
    trace.write_text("".join(json.dumps(line) + "\n" for line in lines))
    data = as_json(run("--json", "decode", str(trace), port=None))
    frames = data["frames"]
    assert [f["time"] for f in frames] == [0.5, 0.52, 0.53]
    assert [f["inferred"] for f in frames] == [False, False, False]
    human = run("decode", str(trace), port=None)
    assert human.exit_code == 0
    assert "ReadStatus" in human.stdout
    assert "servo_on+origin" in human.stdout
    assert "3 frame(s)" in human.stdout


def test_xxd_and_hexdump_c_output_are_read() -> None:
    request = encode_packet(ReadStatus().encode())
    xxd = "00000000: 02ff 4141 03ff                           ..AA..\n"
    hexdump_c = "00000000  02 ff 41 41 03 ff                                 |..AA..|\n"
    assert parse_hexdump(xxd) == [Chunk(request)]
    assert parse_hexdump(hexdump_c) == [Chunk(request)]
    assert parse_hexdump("TX: 0x02 0xff 0x41 0x41 0x03 0xff  # AA\n") == [
        Chunk(request, Direction.TO_CONTROLLER)
    ]


def test_human_output_reads_as_a_table(run: Run) -> None:
    result = run("decode", "--hex", status_dump(), port=None)
    assert result.exit_code == 0
    out = result.stdout
    assert "request" in out and "answer" in out and "ack" in out
    assert "H→C" in out and "C→H" in out


def test_stdin_source(run: Run, as_json: AsJson) -> None:
    result = run("--json", "decode", "-", input=status_dump(), port=None)
    assert len(as_json(result)["frames"]) == 3


def test_bad_input_is_a_usage_error(run: Run, tmp_path: Path) -> None:
    bad = run("decode", "--hex", "02 zz", port=None)
    assert bad.exit_code == 2
    assert "not a hex byte" in bad.stderr
    missing = run("decode", str(tmp_path / "nope.bin"), port=None)
    assert missing.exit_code == 2
    assert "cannot read" in missing.stderr.lower()
    neither = run("--json", "decode", port=None)
    assert neither.exit_code == 2
    assert json.loads(neither.stderr)["error"]["exit_code"] == 2


def test_capture_that_ends_inside_a_frame_says_so() -> None:
    request = encode_packet(ReadStatus().encode())
    frames = annotate(parse_capture(request[:-2], CaptureFormat.RAW))
    assert [f.kind for f in frames] == ["partial"]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(min_value=1, max_value=7), min_size=1, max_size=20))
def test_any_split_of_the_capture_gives_the_same_frames(cuts: list[int]) -> None:
    request, answers = frames_of(ReadAlarms(), (Alarm(1153, "T/P Emergency"),))
    stream = request + b"".join(a + ACK_BYTE for a in answers)
    whole = annotate([Chunk(stream)])
    pieces, pos = [], 0
    for cut in cuts:
        pieces.append(Chunk(stream[pos : pos + cut]))
        pos += cut
    pieces.append(Chunk(stream[pos:]))
    split = annotate(pieces)
    assert [(f.kind, f.command, f.flag, f.fields) for f in split] == [
        (f.kind, f.command, f.flag, f.fields) for f in whole
    ]
