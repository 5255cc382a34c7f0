"""``robostar serve modbus-map``: the Modbus face's register map, for the PLC's programmer."""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Sequence

import click

from robostar.errors import UsageError

__all__ = ["modbus_map", "render_map"]

_COLUMNS = ("table", "address", "plc", "count", "type", "access", "name", "description")


def _elements(name: str, words: int) -> list[str] | None:
    """The names of a group's elements (``io.in.0.0-15``: ``io.in.0.0`` to ``io.in.0.15``),
    None for a field that is one value (a float, a text)."""
    prefix, dot, span = name.rpartition(".")
    first, dash, last = span.partition("-")
    if not dot or not dash or not first.isdigit() or not last.isdigit():
        return None
    if int(last) - int(first) + 1 != words:
        return None
    return [f"{prefix}.{n}" for n in range(int(first), int(last) + 1)]


def _rows(
    ints: tuple[int, int], floats: tuple[int, int], *, per_tag: bool = False
) -> list[tuple[str, ...]]:
    """The map's rows: a field a row, its addresses as ranges (``100-115``); or, ``per_tag``
    (for a PLC tool's import), a row per tag with its first address alone: a group of bits or
    codes is a tag per element, a float or a text one tag of ``count`` registers."""
    from robostar.serve.faces.modbus.layout import GlobalRange, register_map

    rows: list[tuple[str, ...]] = []
    for f in register_map(GlobalRange(*ints), GlobalRange(*floats)):
        access = "read/write" if f.writable else "read"
        names = _elements(f.name, f.words) if per_tag else None
        if names is not None:
            for n, name in enumerate(names):
                address, plc = str(f.address + n), str(f.plc_address + n)
                rows.append((f.table.value, address, plc, "1", f.type, access, name, f.description))
            continue
        if per_tag or f.words == 1:
            span, plc = str(f.address), str(f.plc_address)
        else:
            span = f"{f.address}-{f.last}"
            plc = f"{f.plc_address}-{f.plc_address + f.words - 1}"
        rows.append((f.table.value, span, plc, str(f.words), f.type, access, f.name, f.description))
    return rows


def _codes() -> list[tuple[str, list[tuple[str, ...]]]]:
    """The tables of numbers the registers hold: commands, outcomes, reasons, qualities."""
    from robostar.serve.faces.modbus.handshake import CODES
    from robostar.serve.faces.modbus.layout import Outcome, Quality, Reason

    def named(kind: Iterable[Outcome | Reason | Quality]) -> list[tuple[str, ...]]:
        return [(str(int(m)), m.name.lower()) for m in kind]

    return [
        ("command codes (cmd.code)", [(str(c), name) for c, (name, _) in CODES.items()]),
        ("outcomes (cmd.outcome)", named(Outcome)),
        ("reasons (cmd.reason)", named(Reason)),
        ("block qualities (health.*.quality)", named(Quality)),
    ]


def _markdown(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell.replace("|", "\\|") for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    out = [
        "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
        for row in [header, *rows]
    ]
    return "\n".join(out)


def render_map(fmt: str, ints: tuple[int, int] = (0, 0), floats: tuple[int, int] = (0, 0)) -> str:
    """The map as ``table``, ``csv`` (one row per tag, its first address a number, for a PLC
    tool's import) or
    ``markdown`` (the map and the code tables, as docs/modbus.md shows them)."""
    from robostar.serve.faces.modbus.layout import MAP_VERSION

    if fmt == "csv":
        rows = _rows(ints, floats, per_tag=True)
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(_COLUMNS)
        writer.writerows(rows)
        return buffer.getvalue()
    rows = _rows(ints, floats)
    render = _markdown if fmt == "markdown" else _table
    heading = "### " if fmt == "markdown" else ""
    parts = [f"{heading}Modbus register map, version {MAP_VERSION}", render(_COLUMNS, rows)]
    for title, codes in _codes():
        parts += [heading + title, render(("value", "meaning"), codes)]
    return "\n\n".join(parts) + "\n"


def _range(text: str | None, option: str) -> tuple[int, int]:
    if text is None:
        return (0, 0)
    first, sep, count = text.partition(":")
    if not sep or not first.isdigit() or not count.isdigit():
        raise UsageError(f"{option} {text!r}: expected FIRST:COUNT, e.g. 0:16")
    from robostar.serve.faces.modbus.layout import MAX_GLOBALS

    if int(count) > MAX_GLOBALS:
        raise UsageError(f"{option} {text!r}: the map holds {MAX_GLOBALS} at most")
    return int(first), int(count)


@click.command("modbus-map")
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["table", "csv", "markdown"]),
    default="table",
    show_default=True,
)
@click.option(
    "--config",
    "config_file",
    type=click.Path(dir_okay=False),
    help="Take the global ranges from this file's [modbus] section.",
)
@click.option("--ints", metavar="FIRST:COUNT", help="The global ints shown (e.g. 0:16).")
@click.option("--floats", metavar="FIRST:COUNT", help="The global floats shown (e.g. 0:8).")
def modbus_map(fmt: str, config_file: str | None, ints: str | None, floats: str | None) -> None:
    """Print the Modbus face's register map (the same for every line).

    \b
    Examples:
      robostar serve modbus-map
      robostar serve modbus-map --format csv --ints 0:16 > robostar-map.csv
      robostar serve modbus-map --config serve.toml --format markdown
    """
    int_range, float_range = _range(ints, "--ints"), _range(floats, "--floats")
    if config_file is not None:
        from robostar.serve.config import load_config
        from robostar.serve.faces.modbus.settings import settings_from

        options = load_config(config_file).faces.get("modbus")
        if options is None:
            raise UsageError(f"{config_file}: no [modbus] section")
        settings = settings_from(options)
        int_range = (settings.ints.first, settings.ints.count)
        float_range = (settings.floats.first, settings.floats.count)
    click.echo(render_map(fmt, int_range, float_range), nl=False)
