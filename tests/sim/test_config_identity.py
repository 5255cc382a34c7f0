"""The simulator's mark: AD's version always ends in -SIM, whatever sets the simulator up.

No configuration (code, sim:// query, TOML), dialect, state directory or replayed recording
gives a simulator an AD identity without the mark, and the answer stays a valid AD answer of
the manual's widths (robostar.commands.identity).
"""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest
from sim_harness import Harness

from robostar import Client
from robostar.commands.identity import is_simulator_identity, simulator_version
from robostar.commands.status import ReadInfo
from robostar.protocol.frame import encode_packet
from robostar.sim import SimConfig, VirtualController
from robostar.sim.dialects import DIALECTS
from robostar.sim.listeners import serve
from robostar.sim.replay import Recorded, ReplayController, mark_identity
from robostar.sim.store import STATE_FILE, StateStore
from robostar.transport import PeerTransport
from robostar.types import ChannelInfo, ControllerInfo, RobotType

ROBOT_VERSION = "N1RO 03.02.05"
AD_REQUEST = encode_packet(b"\xffAD")
ACK, NAK = b"\x06", b"\x15"


def _info(version: str, name: str = "N1") -> ControllerInfo:
    channels = (
        ChannelInfo(1, "RSA60A", RobotType.SCARA, 4, (1, 2, 3, 4)),
        ChannelInfo(2, "", RobotType.NOT_DEFINED, 0, ()),
        ChannelInfo(3, "", RobotType.NOT_DEFINED, 0, ()),
    )
    return ControllerInfo(1, name, version, channels)


@pytest.mark.parametrize(
    ("configured", "served"),
    [
        (ROBOT_VERSION, "N1RO 03.02.05-SIM"),
        ("N1RO 03.02.05-SIM", "N1RO 03.02.05-SIM"),  # the default, kept as it is
        ("N1RO 03.02.05-SB", "N1RO 03.02.05-SB-SIM"),  # the manual's example fills the field
        ("N1RO 03.02.05-SB-XY", "N1RO 03.02.05-SB-SIM"),  # cut to fit 20 bytes
        ("V" * 20, "V" * 16 + "-SIM"),
        ("  N1RO 1.0  ", "N1RO 1.0-SIM"),
        ("", "-SIM"),
        ("v1-sim", "v1-sim"),
    ],
)
def test_the_served_version_always_ends_in_the_mark(configured: str, served: str) -> None:
    assert simulator_version(configured) == served
    assert len(served) <= 20
    assert SimConfig(version=configured).served_version == served
    assert is_simulator_identity(_info(served))


@pytest.mark.parametrize(
    "version", [ROBOT_VERSION, "N1RO 03.02.05-SB", "N1-SIM 1.0", "SIM", "N1RO-SIMX"]
)
def test_a_version_without_the_mark_is_a_controller(version: str) -> None:
    assert not is_simulator_identity(_info(version))


def test_the_name_does_not_make_a_simulator() -> None:
    # NAME is set on a real N1 by its owner (the manual's "1.3.4.4 NAME"): PRESS-SIM is a name.
    assert not is_simulator_identity(_info(ROBOT_VERSION, name="PRESS-SIM"))
    assert is_simulator_identity(_info(f"{ROBOT_VERSION}-SIM", name="N1"))


@pytest.mark.parametrize("dialect", sorted(DIALECTS))
def test_ad_carries_the_mark_in_every_dialect(dialect: str) -> None:
    config = SimConfig(name="N1", version=ROBOT_VERSION, dialect=dialect)
    info = Harness(config).ok(ReadInfo())
    assert (info.name, info.version) == ("N1", "N1RO 03.02.05-SIM")
    assert is_simulator_identity(info)


def test_the_ad_answer_keeps_the_manuals_widths() -> None:
    sim = VirtualController(SimConfig(name="N1", version="V" * 20))
    sim.feed(AD_REQUEST, 0.0)
    answer = sim.output(0.0)
    assert answer[:1] == b"\x02" and answer[-2:-1] == b"\x03"
    data = answer[1:-2]
    # FF, FLAG, MAX CH, NAME 15, VER 20, MODEL 3x10, 9 channel bytes.
    assert len(data) == 2 + 1 + 15 + 20 + 30 + 9
    assert data[3:18] == b"N1".ljust(15) and data[18:38] == b"V" * 16 + b"-SIM"


@pytest.mark.parametrize(
    "query",
    [
        {"name": "N1", "version": ROBOT_VERSION},
        {"version": "N1RO 03.02.05-SB"},
        {"version": ""},
    ],
)
def test_no_sim_url_removes_the_mark(query: dict[str, str]) -> None:
    config = SimConfig.from_query(query)
    assert Harness(config).ok(ReadInfo()).version.endswith("-SIM")


def test_no_configuration_file_removes_the_mark(tmp_path: Path) -> None:
    toml = tmp_path / "robot.toml"
    toml.write_text(f'name = "N1"\nversion = "{ROBOT_VERSION}"\n')
    info = Harness(SimConfig.from_file(toml)).ok(ReadInfo())
    assert (info.name, info.version) == ("N1", "N1RO 03.02.05-SIM")


def test_no_state_directory_removes_the_mark(tmp_path: Path) -> None:
    # The state file holds what a controller keeps across power-off; edited by hand to read as
    # a robot's, it still gives AD no identity (AD comes from the configuration alone).
    snapshot = VirtualController(SimConfig()).model.snapshot()
    snapshot["parameters"] = {key: f"NAME: N1 {ROBOT_VERSION}" for key in snapshot["parameters"]}
    StateStore(tmp_path).save(snapshot)
    info = Harness(store=StateStore(tmp_path), name="N1", version=ROBOT_VERSION).ok(ReadInfo())
    assert info.version == "N1RO 03.02.05-SIM" and is_simulator_identity(info)
    assert json.loads((tmp_path / STATE_FILE).read_text())["parameters"] == snapshot["parameters"]


# -- a replayed recording of a real controller ------------------------------------------------


def _recorded_ad(version: str) -> bytes:
    (data,) = ReadInfo().encode_answer(_info(version, name="LINE3"))
    return encode_packet(data)


def _trace(path: Path, frames: list[tuple[str, bytes]]) -> Path:
    lines = [json.dumps({"direction": d, "hex": f.hex(), "kind": ""}) for d, f in frames]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_replayed_robot_answers_ad_with_the_mark(tmp_path: Path) -> None:
    trace = _trace(
        tmp_path / "field.trace",
        [("tx", AD_REQUEST), ("rx", _recorded_ad(ROBOT_VERSION)), ("tx", ACK)],
    )
    replay = ReplayController(trace)
    with Client(PeerTransport(replay), timeout=0.5) as client:
        info = client.info()
    assert (info.name, info.version) == ("LINE3", "N1RO 03.02.05-SIM")
    assert replay.divergences == [] and replay.finished


def test_the_replay_marks_resent_ad_answers_and_leaves_the_rest() -> None:
    answer = _recorded_ad(ROBOT_VERSION)
    status = encode_packet(b"0\x80\x80\x80")
    frames = [
        Recorded("tx", AD_REQUEST, ""),
        Recorded("rx", answer, ""),
        Recorded("tx", NAK, ""),
        Recorded("rx", answer, ""),  # the recorded controller's resend
        Recorded("tx", ACK, ""),
        Recorded("tx", encode_packet(b"\xffAA"), ""),
        Recorded("rx", status, ""),
        Recorded("tx", ACK, ""),
    ]
    marked = mark_identity(frames)
    assert marked[1].frame == marked[3].frame == _recorded_ad("N1RO 03.02.05-SIM")
    assert [f.frame for i, f in enumerate(marked) if i not in (1, 3)] == [
        f.frame for i, f in enumerate(frames) if i not in (1, 3)
    ]


def test_a_recorded_ad_answer_that_does_not_decode_is_played_as_recorded() -> None:
    refused = encode_packet(b"\xff2")
    corrupt = _recorded_ad(ROBOT_VERSION)[:-1] + b"\x00"
    for frame in (refused, corrupt):
        frames = [Recorded("tx", AD_REQUEST, ""), Recorded("rx", frame, "")]
        assert mark_identity(frames)[1].frame == frame


@pytest.mark.parametrize(("version", "said"), [(ROBOT_VERSION, True), ("N1RO 03.02.05-SIM", False)])
def test_serve_says_when_it_adds_the_mark(
    version: str, said: bool, capsys: pytest.CaptureFixture[str]
) -> None:
    stop = threading.Event()
    config = SimConfig(name="N1", version=version)
    serve(config, listen="127.0.0.1:0", stop=stop, on_ready=lambda endpoints: stop.set())
    err = capsys.readouterr().err
    assert ("answers AD with version 'N1RO 03.02.05-SIM'" in err) is said
    assert ("always ends in -SIM" in err) is said
