"""The fault matrix: client <-> simulator through the fault injector, one test per row.

A row is (exchange, fault, direction); its cells are the byte positions of the exchange in that
direction (``reliability/matrix.py`` says how a cell is judged). CI runs every position of the
short exchanges and every 9th/6th of FA/FB; ``pytest tests/reliability --full`` runs them all.
Rows where the matrix found a library bug are strict xfails naming the cause, so that a fix
makes them pass and the lead flips them.
"""

from __future__ import annotations

import pytest
from reliability.matrix import (
    CASES,
    CI_STRIDE,
    FAULTS,
    SCENARIOS,
    Case,
    CellResult,
    Fault,
    MatrixConfig,
    Scenario,
    Trial,
    baseline,
    rows,
    run_cell,
    run_row,
    run_scenario,
)
from reliability.vclock import virtual_time

from robostar.commands.control import StartJob
from robostar.errors import FunctionFailedError, OutcomeUnknownError
from robostar.sim.faults import Direction, FaultKind

CONFIG = MatrixConfig()

KNOWN: dict[tuple[str, str, str], str] = {}
"""Rows with violations, and why (see docs/reliability.md, "Bugs found"); empty since the
five bugs the matrix found were fixed. A new one goes here as a strict xfail with its cause."""


def _id(row: tuple[Case, Fault, Direction]) -> str:
    case, fault, direction = row
    return f"{case.name}-{fault.name.replace(' ', '')}-{direction.value}"


def _report(bad: list[CellResult]) -> str:
    lines = [f"{len(bad)} violating cells:"]
    lines += [f"  @{r.position}: {r.outcome}: {r.detail}" for r in bad[:8]]
    lines += [f"  trace of @{bad[0].position}:"]
    lines += [f"    {way} {data}" for way, data in bad[0].trace]
    return "\n".join(lines)


@pytest.mark.parametrize("row", list(rows()), ids=_id)
def test_matrix_row(row: tuple[Case, Fault, Direction], request: pytest.FixtureRequest) -> None:
    case, fault, direction = row
    full = request.config.getoption("--full")
    key = (case.name, fault.name, direction.value)
    reason = KNOWN.get(key)
    if reason:
        request.applymarker(pytest.mark.xfail(strict=True, reason=reason))
    stride = 1 if full else CI_STRIDE.get(case.name, 1)
    results = run_row(case, fault, direction, CONFIG, stride)
    assert results, "the row has no cells"
    assert not [r for r in results if r.outcome == "not reached"], "a fault did not fire"
    bad = [r for r in results if r.violation]
    assert not bad, _report(bad)


@pytest.mark.parametrize(
    ("scenario", "case"),
    [(s, c) for s in SCENARIOS for c in s.cases],
    ids=[f"{s.name.replace(' ', '-')}-{c.name}" for s in SCENARIOS for c in s.cases],
)
def test_matrix_scenario_row(scenario: Scenario, case: Case) -> None:
    # A controller resending past the manual's limit; an answer held past the client's timeout
    # and quiet gap, then the next read (reliability/matrix.py, SCENARIOS).
    result = run_scenario(scenario, case, CONFIG)
    assert not result.violation, _report([result])


def test_every_shape_is_in_the_matrix() -> None:
    shapes = {case.command.SHAPE.value for case in CASES}
    assert shapes == {"single", "multi", "two-phase", "upload"}
    assert {case.name for case in CASES} == {"AA", "AB", "DB", "FA", "FB", "BD", "CC", "GW"}
    assert {f.name for f in FAULTS} >= {"corrupt", "drop", "duplicate", "delay", "RST"}


def test_the_long_exchanges_are_long() -> None:
    # "FA download of a long job": dozens of packets, each a place for a fault.
    fa = baseline(next(c for c in CASES if c.name == "FA"), CONFIG)
    fb = baseline(next(c for c in CASES if c.name == "FB"), CONFIG)
    assert fa.rx > 500 and len(fa.result.lines) == 40
    assert len(fb.host_packets) == 22  # request, 20 lines, the closing 0x34


REAL_TIME = MatrixConfig(timeout=2.0, ack_timeout=0.6, virtual=False)
REAL_CELLS = [
    ("AA", "corrupt", Direction.TO_HOST, 2),
    ("AA", "duplicate", Direction.TO_CONTROLLER, 1),
    ("AB", "NAK x2", Direction.TO_CONTROLLER, 0),
    ("GW", "RST", Direction.TO_CONTROLLER, 10),
    ("DB", "corrupt", Direction.TO_HOST, 3),
    # An upload line is resent once for a NAK (a later NAK may be a doubled one: the upload
    # then ends on a timer, with UploadIncompleteError), so this cell has one NAK.
    ("FB", "NAK x1", Direction.TO_CONTROLLER, 40),
]


@pytest.mark.parametrize(("name", "fault_name", "direction", "position"), REAL_CELLS)
def test_the_virtual_clock_agrees_with_real_time(
    name: str, fault_name: str, direction: Direction, position: int
) -> None:
    # Cells that never wait on a timer end the same on the real clock as on the virtual one.
    case = next(c for c in CASES if c.name == name)
    fault = next(f for f in FAULTS if f.name == fault_name)
    base = baseline(case, REAL_TIME)
    real = run_cell(case, fault, direction, position, REAL_TIME, base)
    virtual_config = MatrixConfig(timeout=2.0, ack_timeout=0.6)
    virtual = run_cell(case, fault, direction, position, virtual_config, base)
    assert real.outcome == virtual.outcome == "ok", (real, virtual)


def test_a_late_answer_is_never_taken_for_the_next_commands_result() -> None:
    # GW's answer is held 1.5 timeouts on its way (the write was done: OutcomeUnknownError).
    # The next command, CC on a channel with no job, is refused by the controller (0x32); the
    # client must not report success on the strength of GW's late "0" answer.
    gw = next(c for c in CASES if c.name == "GW")
    trial = Trial(gw, CONFIG)
    with virtual_time(trial.clock):
        trial.injector.schedule(FaultKind.DELAY, Direction.TO_HOST, at_byte=0, seconds=1.5)
        with pytest.raises(OutcomeUnknownError):
            trial.call(gw.command)
        trial.injector.clear()
        with pytest.raises(FunctionFailedError):
            trial.call(StartJob(2))
    assert trial.sim.executions["CC"] == 0
