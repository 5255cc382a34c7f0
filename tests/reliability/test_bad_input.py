"""Bad input to every public client method: a clear error naming the argument, nothing sent.

Each case calls one method of :class:`robostar.Client` with one argument out of range, of the
wrong type or malformed. It must raise :class:`~robostar.errors.UsageError` (FieldError is one)
whose message names that argument, and the wire trace must show no byte sent. The CLI's
commands get the same treatment in ``test_bad_cli_input.py``.
"""

from __future__ import annotations

import asyncio
import inspect
import math
from collections.abc import Iterator
from typing import Any

import pytest

from robostar.client import AsyncClient, Client, TraceRecord
from robostar.commands.variables import ReadGlobalInt
from robostar.errors import UsageError
from robostar.types import ArmForm, Point

P = Point((1.0, 2.0, 3.0, 4.0), ArmForm.NONE, True)
NAN = math.nan

# (method, args, kwargs, the argument the message must name)
Case = tuple[str, tuple[Any, ...], dict[str, Any], str]


def _channel_cases() -> Iterator[Case]:
    """Every method with a channel, given a bad one (the others' arguments valid)."""
    valid_rest: dict[str, tuple[Any, ...]] = {
        "position": (),
        "wait_stopped": (),
        "wait_homed": (),
        "home": (),
        "move_to_point": ("DEMO.PNT", 1),
        "move": ((1.0, 2.0, 3.0, 4.0),),
        "move_by": ((1.0, 0.0, 0.0, 0.0),),
        "speed": (),
        "set_speed": (500,),
        "start_job": (),
        "stop_job": (),
        "reset_job": (),
        "stop_homing": (),
        "set_reference_axis": (1,),
        "reference_axis": (),
        "servo": (True,),
        "select_job": ("DEMO.JOB",),
        "set_step_mode": (True,),
        "job_step": (),
        "job_name": (),
        "download_job": ("DEMO.JOB",),
        "download_points": ("DEMO.PNT",),
        "upload_job": ("NEW.JOB", ["MAIN", "EOP"]),
        "upload_points": ("NEW.PNT", {1: P}),
        "file_exists": ("DEMO.JOB",),
        "list_files": (),
        "delete_file": ("DEMO.JOB",),
        "copy_file": ("DEMO.JOB", "COPY.JOB"),
        "rename_file": ("DEMO.JOB", "NEW.JOB"),
        "read_global_point": (5,),
        "write_global_point": (5, P),
        "parameters": (),
    }
    for method, rest in valid_rest.items():
        for bad in (0, 4, -1, "1", 1.0, True, None):
            if method == "parameters" and bad is None:
                continue  # None asks for the public parameters
            yield method, (bad, *rest), {}, "channel"


NAME_CASES: list[Case] = [
    (method, (1, bad, *rest), {}, name)
    for method, name, rest in (
        ("move_to_point", "file", (1,)),
        ("select_job", "name", ()),
        ("download_job", "name", ()),
        ("download_points", "name", ()),
        ("upload_job", "name", (["MAIN", "EOP"],)),
        ("upload_points", "name", ({1: P},)),
        ("file_exists", "name", ()),
        ("delete_file", "name", ()),
        ("copy_file", "name", ("COPY.JOB",)),
        ("rename_file", "name", ("NEW.JOB",)),
    )
    for bad in ("TOOLONG.JOB", "Mixed.JOB", "A-B.JOB", "DEMO.TXT", "", 42, None)
]
"""Every method with a file name, given a bad one."""

OTHER_CASES: list[Case] = [
    ("position", (1,), {"kind": "polar"}, "kind"),
    ("position", (1,), {"kind": 7}, "kind"),
    ("wait_stopped", (1,), {"timeout": -1}, "timeout"),
    ("wait_stopped", (1,), {"timeout": "soon"}, "timeout"),
    ("wait_homed", (1,), {"timeout": 0}, "timeout"),
    ("home", (1,), {"wait": True, "timeout": NAN}, "timeout"),
    ("home", (1,), {"wait": "yes"}, "wait"),
    ("home", (1,), {"timeout": NAN}, "timeout"),
    ("move", (1, (1.0, 2.0)), {"timeout": -1}, "timeout"),
    ("move_to_point", (1, "DEMO.JOB", 1), {}, "file"),
    ("move_to_point", (1, "DEMO.PNT", -1), {}, "point"),
    ("move_to_point", (1, "DEMO.PNT", 10_000), {}, "point"),
    ("move_to_point", (1, "DEMO.PNT", "3"), {}, "point"),
    ("move_to_point", (1, "DEMO.PNT", 2), {"via": -1}, "point"),
    ("move_to_point", (1, "DEMO.PNT", 2), {"motion": "fly"}, "motion"),
    ("move", (1, ()), {}, "target"),
    ("move", (1, (1.0,) * 7), {}, "target"),
    ("move", (1, ("a", 2.0)), {}, "target"),
    ("move", (1, (NAN, 2.0)), {}, "target"),
    ("move", (1, (1e12, 2.0)), {}, "target"),
    ("move", (1, "1,2,3"), {}, "target"),
    ("move", (1, (1.0, 2.0)), {"coords": "polar"}, "coords"),
    ("move", (1, (1.0, 2.0)), {"motion": "fly"}, "motion"),
    ("move", (1, (1.0, 2.0)), {"via": ()}, "via"),
    ("move_by", (1, ()), {}, "delta"),
    ("move_by", (1, (math.inf,)), {}, "delta"),
    ("move_by", (1, (1.0,)), {"motion": "arc"}, "motion"),
    ("move_by", (1, (1.0,)), {"coords": 3}, "coords"),
    ("set_speed", (1, -1), {}, "speed"),
    ("set_speed", (1, 1001), {}, "speed"),
    ("set_speed", (1, "500"), {}, "speed"),
    ("set_speed", (1, 500.0), {}, "speed"),
    ("set_speed", (1, True), {}, "speed"),
    ("set_reference_axis", (1, 2), {}, "axis"),
    ("set_reference_axis", (1, "1"), {}, "axis"),
    ("servo", (1, "yes"), {}, "on"),
    ("servo", (1, None), {}, "on"),
    ("set_step_mode", (1, "step"), {}, "step"),
    ("download_points", (1, "DEMO.PNT"), {"coords": "polar"}, "coords"),
    ("upload_job", (1, "NEW.JOB", "MAIN\nEOP"), {}, "lines"),
    ("upload_job", (1, "NEW.JOB", [1, 2]), {}, "line 1"),
    ("upload_job", (1, "NEW.JOB", ["MAIN", "a\nb"]), {}, "line 2"),
    ("upload_job", (1, "NEW.JOB", ["MAIN", "x" * 200]), {}, "line 2"),
    ("upload_job", (1, "NEW.JOB", ["MAIN", "caf\u00e9"]), {}, "line 2"),
    ("upload_job", (1, "NEW.JOB", ["MAIN"]), {"number": 201}, "number"),
    ("upload_job", (1, "NEW.JOB", ["MAIN"]), {"number": -1}, "number"),
    ("upload_job", (1, "NEW.JOB", ["MAIN"]), {"number": "7"}, "number"),
    ("upload_points", (1, "NEW.PNT", "P1"), {}, "points"),
    ("upload_points", (1, "NEW.PNT", {1: "p"}), {}, "point"),
    ("upload_points", (1, "NEW.PNT", {-1: P}), {}, "point"),
    ("upload_points", (1, "NEW.PNT", {1: Point((NAN,))}), {}, "point"),
    ("list_files", (1, "??"), {}, "pattern"),
    ("list_files", (1, 5), {}, "pattern"),
    ("copy_file", (1, "DEMO.JOB", "COPY.JOB"), {"to_channel": 5}, "to_channel"),
    ("copy_file", (1, "DEMO.JOB", "TOOLONG.JOB"), {}, "new_name"),
    ("rename_file", (1, "DEMO.JOB", "Bad.JOB"), {}, "new_name"),
    ("inputs", (-1,), {}, "port"),
    ("inputs", (5,), {}, "port"),
    ("inputs", ("0",), {}, "port"),
    ("outputs", (5,), {}, "port"),
    ("outputs", (None,), {}, "port"),
    ("set_output", (5, 0, True), {}, "port"),
    ("set_output", (0, 16, True), {}, "contact"),
    ("set_output", (0, -1, True), {}, "contact"),
    ("set_output", (0, 1, "on"), {}, "on"),
    ("read_global_point", (1, -1), {}, "index"),
    ("read_global_point", (1, 1024), {}, "index"),
    ("read_global_point", (1, "5"), {}, "index"),
    ("read_global_point", (1, 5), {"axis": 7}, "axis"),
    ("read_global_point", (1, 5), {"coords": "polar"}, "coords"),
    ("read_global_int", (500,), {}, "index"),
    ("read_global_int", (-1,), {}, "index"),
    ("read_global_int", (1.5,), {}, "index"),
    ("read_global_float", (500,), {}, "index"),
    ("write_global_point", (1, 1024, P), {}, "index"),
    ("write_global_point", (1, 5, ()), {}, "point"),
    ("write_global_point", (1, 5, ("a",)), {}, "point"),
    ("write_global_point", (1, 5, Point((1.0,) * 7)), {}, "point"),
    ("write_global_point", (1, 5, P), {"axis": 7}, "axis"),
    ("write_global_int", (500, 1), {}, "index"),
    ("write_global_int", (1, "1"), {}, "value"),
    ("write_global_int", (1, 1.5), {}, "value"),
    ("write_global_int", (1, 10**7), {}, "value"),
    ("write_global_float", (500, 1.0), {}, "index"),
    ("write_global_float", (1, NAN), {}, "value"),
    ("write_global_float", (1, math.inf), {}, "value"),
    ("write_global_float", (1, "1.0"), {}, "value"),
    ("write_global_float", (1, 1e7), {}, "value"),
    ("parameters", (1,), {"index": 0}, "index"),
    ("parameters", (1,), {"index": 100}, "index"),
    ("parameters", (1,), {"index": -2}, "index"),
    ("parameters", (1,), {"index": "1"}, "index"),
    ("execute", ("AA",), {}, "command"),
    ("execute", (ReadGlobalInt(600),), {}, "index"),
    ("jog", (0, 1, "+"), {}, "channel"),
    ("jog", (1, 7, "+"), {}, "axis"),
    ("jog", (1, 1, "up"), {}, "direction"),
    ("jog", (1, 1, "+"), {"motion": "arc"}, "motion"),
    ("jog", (1, 1, "+"), {"interval": 0.5}, "interval"),
    ("backup", (42,), {}, "folder"),
    ("restore", ("/nonexistent/robostar-backup",), {}, "folder"),
]

CASES: list[Case] = [*_channel_cases(), *NAME_CASES, *OTHER_CASES]


def _id(case: Case) -> str:
    method, args, kwargs, name = case
    shown = [repr(a)[:12] for a in args] + [f"{k}={v!r}"[:16] for k, v in kwargs.items()]
    return f"{method}({','.join(shown)})->{name}"


@pytest.fixture(scope="module")
def wire() -> Iterator[tuple[Client, list[TraceRecord]]]:
    records: list[TraceRecord] = []
    client = Client("sim://?speedup=50", trace=records.append)
    yield client, records
    client.close()


@pytest.mark.parametrize("case", CASES, ids=_id)
def test_bad_argument_is_refused_before_anything_is_sent(
    case: Case, wire: tuple[Client, list[TraceRecord]]
) -> None:
    client, records = wire
    method, args, kwargs, name = case
    sent_before = [r for r in records if r.direction == "tx"]
    with pytest.raises(UsageError) as caught:
        result = getattr(client, method)(*args, **kwargs)
        if method == "jog":  # a Jog starts when entered: the arguments are checked before
            result.stop()
    assert name in str(caught.value), f"the error does not name {name!r}: {caught.value}"
    assert [r for r in records if r.direction == "tx"] == sent_before, "bytes were sent"


def test_every_public_method_is_covered() -> None:
    public = {
        name
        for name in dir(Client)
        if not name.startswith("_") and callable(getattr(Client, name)) and name != "close"
    }
    covered = {case[0] for case in CASES}
    takes_no_argument = {
        "status",
        "alarms",
        "info",
        "emergency_stop",
        "reset_alarms",
        "restart",
        "alarm_history",
        "io_boards",
        "last_error",
    }
    assert public - covered - takes_no_argument == set()


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"timeout": 0}, "timeout"),
        ({"timeout": -1.0}, "timeout"),
        ({"timeout": "2"}, "timeout"),
        ({"retries": -1}, "retries"),
        ({"retries": 1.5}, "retries"),
        ({"keepalive": 0.5}, "keepalive"),
        ({"poll_interval": 0}, "poll_interval"),
        ({"reconnect": "yes"}, "reconnect"),
    ],
)
def test_bad_client_options_are_refused(kwargs: dict[str, Any], name: str) -> None:
    records: list[TraceRecord] = []
    with pytest.raises(UsageError, match=name):
        Client("sim://", trace=records.append, **kwargs)
    assert records == []


@pytest.mark.parametrize("url", ["nosuch://x", "tcp://:20000", "tcp://127.0.0.1:99999", ""])
def test_bad_port_urls_are_refused(url: str) -> None:
    with pytest.raises(UsageError, match=r"url|port"):
        Client(url)


def test_the_asyncio_client_refuses_the_same_arguments() -> None:
    # The surface is written once; this checks the asyncio binding keeps every check too.
    async def run() -> list[str]:
        records: list[TraceRecord] = []
        problems = []
        async with AsyncClient("sim://?speedup=50", trace=records.append) as client:
            for method, args, kwargs, name in CASES:
                try:
                    # jog() checks its arguments at once and returns an AsyncJog; the rest are
                    # coroutines.
                    result = getattr(client, method)(*args, **kwargs)
                    if inspect.isawaitable(result):
                        await result
                except UsageError as exc:
                    if name not in str(exc):
                        problems.append(f"{method}: {exc} does not name {name}")
                else:
                    problems.append(f"{method}{args}{kwargs}: no error")
        if [r for r in records if r.direction == "tx"]:
            problems.append("bytes were sent")
        return problems

    assert asyncio.run(run()) == []


def test_the_trace_shows_what_a_good_call_sends(wire: tuple[Client, list[TraceRecord]]) -> None:
    # The control for the check above: a valid call does leave its frames in the trace.
    client, records = wire
    before = len([r for r in records if r.direction == "tx"])
    client.set_speed(1, 500)
    assert len([r for r in records if r.direction == "tx"]) > before
