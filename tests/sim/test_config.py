"""SimConfig and ChannelConfig: defaults, sim:// queries, TOML files and refusals."""

from __future__ import annotations

import pytest

from robostar.errors import UsageError
from robostar.sim import ChannelConfig, SimConfig
from robostar.types import RobotType


def test_defaults_are_a_two_channel_n1():
    config = SimConfig()
    assert config.name == "N1-SIM"
    assert config.version == "N1RO 03.02.05-SIM"
    assert [c.robot for c in config.channels] == [RobotType.SCARA, RobotType.XY]
    assert config.auto_servo_on is True
    assert config.io_boards == (1, 1)
    assert config.speedup == 1.0
    assert config.ack_timeout == 2.0
    assert config.seed is None


def test_channel_defaults_follow_the_robot_kind():
    scara = ChannelConfig(RobotType.SCARA, 4)
    assert scara.model == "RSA60A"
    assert scara.limits[0] == (-120.0, 120.0)
    assert scara.link_lengths == (350.0, 250.0)
    assert len(scara.max_speed) == len(scara.pulses_per_unit) == 4
    xy = ChannelConfig(RobotType.XY, 3)
    assert xy.model == "XY"
    assert xy.limits == ((0.0, 600.0),) * 3
    assert xy.can_move
    assert not ChannelConfig(RobotType.BACKGROUND_TASK, 1).can_move


@pytest.mark.parametrize(
    ("fields", "word"),
    [
        ({"axes": 0}, "axes"),
        ({"axes": 7}, "axes"),
        ({"robot": RobotType.SCARA, "axes": 1}, "axes"),
        ({"axes": 2, "limits": ((0, 1),)}, "limits"),
        ({"axes": 1, "robot": RobotType.XY, "limits": ((5, 1),)}, "limits[0]"),
        ({"axes": 1, "robot": RobotType.XY, "max_speed": (0,)}, "max_speed"),
        ({"axes": 1, "robot": RobotType.XY, "pulses_per_unit": (-1,)}, "pulses_per_unit"),
        ({"link_lengths": (350.0, 0.0)}, "link_lengths"),
        ({"model": "ELEVENCHARS"}, "model"),
    ],
)
def test_bad_channel_fields_are_refused_by_name(fields, word):
    with pytest.raises(UsageError, match=word.replace("[", r"\[")):
        ChannelConfig(**fields)


@pytest.mark.parametrize(
    ("fields", "word"),
    [
        ({"channels": ()}, "channels"),
        ({"channels": (ChannelConfig(),) * 4}, "channels"),
        ({"io_boards": (3, 0)}, "io_boards"),
        ({"speedup": 0}, "speedup"),
        ({"ack_timeout": -1}, "ack_timeout"),
        ({"name": "X" * 16}, "name"),
        ({"version": "V" * 21}, "version"),
        ({"seed": "7"}, "seed"),
    ],
)
def test_bad_config_fields_are_refused_by_name(fields, word):
    with pytest.raises(UsageError, match=word):
        SimConfig(**fields)


def test_from_query_reads_the_url_keys():
    config = SimConfig.from_query(
        {"channels": "2", "robot": "scara", "speedup": "20", "auto_servo": "dis", "axes": "4"}
    )
    assert [c.robot for c in config.channels] == [RobotType.SCARA, RobotType.SCARA]
    assert [c.axes for c in config.channels] == [4, 4]
    assert config.speedup == 20.0
    assert config.auto_servo_on is False


def test_from_query_takes_per_channel_lists_and_the_rest():
    config = SimConfig.from_query(
        {
            "robot": "scara,xy,bgt",
            "axes": "4,3,1",
            "io": "2,0",
            "ack_timeout": "0.5",
            "name": "CELL-7",
            "version": "V1",
            "seed": "3",
        }
    )
    assert [c.robot for c in config.channels] == [
        RobotType.SCARA,
        RobotType.XY,
        RobotType.BACKGROUND_TASK,
    ]
    assert [c.axes for c in config.channels] == [4, 3, 1]
    assert config.io_boards == (2, 0)
    assert config.ack_timeout == 0.5
    assert (config.name, config.version, config.seed) == ("CELL-7", "V1", 3)


def test_from_query_with_only_a_channel_count_keeps_the_default_robots():
    assert len(SimConfig.from_query({"channels": "1"}).channels) == 1
    three = SimConfig.from_query({"channels": "3"})
    assert [c.robot for c in three.channels][:2] == [RobotType.SCARA, RobotType.XY]
    assert SimConfig.from_query({}) == SimConfig()


@pytest.mark.parametrize(
    ("query", "word"),
    [
        ({"colour": "red"}, "colour"),
        ({"channels": "4"}, "channels"),
        ({"channels": "two"}, "channels"),
        ({"robot": "delta"}, "robot"),
        ({"robot": "scara,xy", "channels": "3"}, "robot"),
        ({"auto_servo": "maybe"}, "auto_servo"),
        ({"speedup": "fast"}, "speedup"),
        ({"speedup": "inf"}, "speedup"),
        ({"io": "1"}, "io"),
    ],
)
def test_from_query_refuses_bad_keys_and_values(query, word):
    with pytest.raises(UsageError, match=word):
        SimConfig.from_query(query)


def test_from_file_reads_toml(tmp_path):
    path = tmp_path / "cell.toml"
    path.write_text(
        """
name = "CELL-1"
auto_servo_on = false
io_boards = [2, 2]
speedup = 10.0
seed = 9

[[channels]]
robot = "scara"
axes = 4
link_lengths = [300.0, 200.0]
limits = [[-100, 100], [-120, 120], [0, 150], [-180, 180]]

[[channels]]
robot = "xy"
axes = 2
max_speed = [500, 400]
"""
    )
    config = SimConfig.from_file(path)
    assert config.name == "CELL-1"
    assert config.auto_servo_on is False
    assert config.io_boards == (2, 2)
    assert config.speedup == 10.0
    assert config.seed == 9
    scara, xy = config.channels
    assert scara.link_lengths == (300.0, 200.0)
    assert scara.limits[2] == (0.0, 150.0)
    assert xy.max_speed == (500.0, 400.0)


@pytest.mark.parametrize(
    ("text", "word"),
    [
        ("speedup = [", "TOML"),
        ("colour = 1", "colour"),
        ("auto_servo_on = 1", "auto_servo_on"),
        ("[[channels]]\nrobot = 'xy'\naxes = 2\ncolour = 1", r"channels\[0\]"),
        ("[[channels]]\nrobot = 'xy'\naxes = 9", r"channels\[0\]\.axes"),
        ("channels = 3", "channels"),
    ],
)
def test_from_file_refuses_bad_content(tmp_path, text, word):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(UsageError, match=word):
        SimConfig.from_file(path)


def test_from_file_names_a_missing_file(tmp_path):
    with pytest.raises(UsageError, match="config file"):
        SimConfig.from_file(tmp_path / "missing.toml")
