"""The Modbus face's register map and settings: no two fields share an address, every field
lies inside its table, only the command block is writable, `robostar serve modbus-map` prints
every field (table, CSV, markdown), and the [modbus] section and --modbus are checked."""

from __future__ import annotations

import csv
import io
from collections import defaultdict
from pathlib import Path

import pytest
from click.testing import CliRunner

from robostar.cli.app import cli
from robostar.cli.serve import build_config
from robostar.cli.serve_modbus import render_map
from robostar.errors import UsageError
from robostar.serve.faces.modbus.layout import (
    DI,
    HR,
    IR,
    MAP_VERSION,
    GlobalRange,
    Table,
    register_map,
)
from robostar.serve.faces.modbus.settings import DEFAULT_ALLOW, settings_from

SIZES = {
    Table.DISCRETE_INPUT: DI.SIZE,
    Table.INPUT_REGISTER: IR.SIZE,
    Table.HOLDING_REGISTER: HR.SIZE,
}


def test_no_two_fields_share_an_address_and_all_fit_their_table() -> None:
    fields = register_map(GlobalRange(0, 100), GlobalRange(400, 100))
    used: dict[Table, set[int]] = defaultdict(set)
    for f in fields:
        span = set(range(f.address, f.address + f.words))
        assert not used[f.table] & span, f
        used[f.table] |= span
        assert f.last < SIZES[f.table], f
        assert f.writable == (f.table is Table.HOLDING_REGISTER and f.last < HR.WRITABLE), f
        if f.type in ("float32", "int32", "uint32"):
            assert f.words == 2, f


def test_the_cli_prints_every_field() -> None:
    runner = CliRunner()
    result = runner.invoke(cli, ["serve", "modbus-map", "--format", "csv", "--ints", "0:4"])
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader(io.StringIO(result.output)))
    assert {"table", "address", "plc", "count", "type", "access", "name"} <= set(rows[0])
    tags = [(row["table"], row["name"]) for row in rows]
    assert len(tags) == len(set(tags))
    names = {row["name"] for row in rows}
    assert {"map_version", "ch1.position.1", "global.int.3", "cmd.sequence"} <= names
    by_name = {row["name"]: row for row in rows}
    assert by_name["map_version"]["plc"] == "30001"
    result = runner.invoke(cli, ["serve", "modbus-map", "--format", "markdown"])
    assert result.exit_code == 0, result.output
    assert f"version {MAP_VERSION}" in result.output
    assert "| 3 | run_job |" in result.output
    assert "| 2 | refused_by_controller |" in result.output
    result = runner.invoke(cli, ["serve", "modbus-map", "--ints", "nonsense"])
    assert result.exit_code != 0 and "FIRST:COUNT" in result.output
    result = runner.invoke(cli, ["serve", "modbus-map", "--floats", "0:101"])
    assert result.exit_code != 0 and "100" in result.output


def test_the_csv_is_a_tag_a_row_with_numbers_a_tool_imports() -> None:
    """A PLC tool's import takes a number in the address column, not "100-115"."""
    result = CliRunner().invoke(cli, ["serve", "modbus-map", "--format", "csv", "--ints", "0:4"])
    rows = list(csv.DictReader(io.StringIO(result.output)))
    for row in rows:
        assert row["address"].isdigit() and row["plc"].isdigit(), row
    by_name = {row["name"]: row for row in rows}
    contact = by_name["io.in.1.3"]  # one tag per contact of a port
    assert (contact["table"], contact["address"], contact["plc"]) == (
        "discrete input",
        "119",
        "10120",
    )
    assert by_name["alarms.code.8"]["address"] == "408"
    x = by_name["ch1.position.1"]  # a float: one tag of two registers
    assert (x["address"], x["plc"], x["count"], x["type"]) == ("112", "30113", "2", "float32")
    tags = sum(
        1 if f.type in ("float32", "int32", "uint32") or f.type.startswith("ascii") else f.words
        for f in register_map(GlobalRange(0, 4))
    )
    assert len(rows) == tags


def test_the_settings_are_checked_key_by_key() -> None:
    lines = {"lines": {"cell1": "127.0.0.1:5020"}}
    settings = settings_from(lines, {"cell1"})
    assert settings.commands == frozenset() and not settings.writes
    enabled = settings_from({**lines, "commands": {"enabled": True}}, {"cell1"})
    assert enabled.commands == frozenset(DEFAULT_ALLOW)  # the stops only, unless named
    bad = [
        ({**lines, "colour": 1}, "modbus.colour"),
        ({"lines": {"cell2": "127.0.0.1:5020"}}, "modbus.lines.cell2"),
        ({"lines": {"cell1": "192.0.2.7:502"}}, "allow_remote"),
        ({**lines, "globals": {"int": {"first": 0, "count": 101}}}, "modbus.globals.int.count"),
        ({**lines, "globals": {"float": {"first": 499, "count": 2}}}, "modbus.globals.float"),
        ({**lines, "commands": {"enabled": True, "allow": ["dance"]}}, "modbus.commands.allow"),
        ({**lines, "globals_interval": 0}, "modbus.globals_interval"),
        ({**lines, "commands": {"enabled": True, "allow": ["run_job"]}}, "without stop_job"),
    ]
    for options, key in bad:
        with pytest.raises(UsageError, match=key):
            settings_from(options, {"cell1"})


def test_the_modbus_option_names_a_line_and_its_port() -> None:
    config = build_config(
        None, ("cell1=sim://",), (), {}, False, None, None, True, ("cell1=127.0.0.1:5020",)
    )
    assert config.faces["modbus"] == {"lines": {"cell1": "127.0.0.1:5020"}}
    with pytest.raises(UsageError, match="--modbus"):
        build_config(None, ("cell1=sim://",), (), {}, False, None, None, True, ("cell1",))


def test_the_docs_show_the_map_as_the_cli_prints_it() -> None:
    docs = Path(__file__).parents[2] / "docs" / "modbus.md"
    text = docs.read_text(encoding="utf-8")
    marker = "This section is that command's\noutput (a test keeps it so).\n\n"
    assert marker in text
    assert text.split(marker, 1)[1] == render_map("markdown"), (
        "docs/modbus.md's map is out of date: rerun `robostar serve modbus-map --format markdown`"
    )


def test_serve_check_takes_a_modbus_section_and_names_a_bad_key(tmp_path: Path) -> None:
    good = tmp_path / "serve.toml"
    good.write_text(
        '[lines.cell1]\nurl = "sim://"\n\n[modbus]\nlines = { cell1 = "127.0.0.1:5020" }\n'
        '[modbus.commands]\nenabled = true\nallow = ["run_job", "stop_job"]\n',
        encoding="utf-8",
    )
    result = CliRunner().invoke(cli, ["serve", "--check", str(good)])
    assert result.exit_code == 0, result.output
    assert "face modbus" in result.output
    bad = tmp_path / "bad.toml"
    bad.write_text(
        '[lines.cell1]\nurl = "sim://"\n\n[modbus]\nlines = { cell1 = "127.0.0.1:5020" }\n'
        '[modbus.commands]\nenabled = true\nallow = ["launch"]\n',
        encoding="utf-8",
    )
    result = CliRunner().invoke(cli, ["serve", "--check", str(bad)])
    assert result.exit_code != 0 and "modbus.commands.allow" in result.output
