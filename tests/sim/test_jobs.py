"""The job language subset: parsing, and the runner stepping in model time."""

from __future__ import annotations

import pytest

from robostar.sim.jobs import STEP_TIME, JobRunner, JobSyntaxError, Op, parse_job


def test_parse_knows_every_statement():
    program = parse_job(
        [
            "MAIN",
            "JMOV P1",
            "lmov p0012",
            "DELAY 250",
            "OUT 1,12,1",
            "WAIT IN 0, 3, 0",
            "loop:",
            "GOTO LOOP",
            "IF I100==0 THEN",
            "END",
            "EOP",
        ]
    )
    ops = [(s.op, s.args) for s in program.steps]
    assert ops == [
        (Op.NOP, ()),
        (Op.JMOV, (1,)),
        (Op.LMOV, (12,)),
        (Op.DELAY, (250,)),
        (Op.OUT, (1, 12, 1)),
        (Op.WAIT, (0, 3, 0)),
        (Op.NOP, ()),
        (Op.GOTO, (6,)),
        (Op.NOP, ()),
        (Op.END, ()),
        (Op.END, ()),
    ]


@pytest.mark.parametrize(
    ("line", "word"),
    [
        ("JMOV X1", "point"),
        ("DELAY soon", "milliseconds"),
        ("OUT 5,0,1", "port 5"),
        ("OUT 0,16,1", "contact 16"),
        ("OUT 0,1", "<port>"),
        ("WAIT 0,1,1", "IN"),
        ("GOTO nowhere", "no such label"),
        ("GOTO 1abc", "label"),
    ],
)
def test_parse_names_the_bad_line(line, word):
    with pytest.raises(JobSyntaxError) as info:
        parse_job(["MAIN", line, "EOP"])
    assert info.value.line == 2
    assert word in info.value.message


def test_a_label_may_not_be_defined_twice():
    with pytest.raises(JobSyntaxError, match="twice"):
        parse_job(["A:", "a:"])


class FakeHost:
    def __init__(self):
        self.moving = False
        self.moves: list[tuple[bool, int, int]] = []
        self.outputs: list[tuple[int, int, bool]] = []
        self.inputs: dict[tuple[int, int], bool] = {}

    def job_move(self, channel, linear, point, line):
        self.moves.append((linear, point, line))
        self.moving = True
        return True

    def job_moving(self, channel):
        return self.moving

    def job_output(self, channel, port, contact, on, line):
        self.outputs.append((port, contact, on))
        return True

    def job_input(self, port, contact):
        return self.inputs.get((port, contact), False)


def run_until(runner: JobRunner, host: FakeHost, start: float, end: float) -> float:
    now = start
    while runner.running and now < end:
        runner.tick(host, now)
        nxt = runner.next_event(now)
        if nxt is None:
            break
        now = max(nxt, now)
    return now


def test_runner_steps_through_a_job_in_model_time():
    host = FakeHost()
    runner = JobRunner(1, parse_job(["MAIN", "OUT 0,1,1", "DELAY 500", "OUT 0,1,0", "EOP"]))
    runner.start(step_mode=False)
    runner.tick(host, 0.0)
    assert host.outputs == []  # MAIN takes a step's time first
    runner.tick(host, STEP_TIME)
    assert host.outputs == [(0, 1, True)]
    runner.tick(host, 2 * STEP_TIME)
    assert runner.step == 3  # in the DELAY
    runner.tick(host, 2 * STEP_TIME + 0.4)
    assert runner.step == 3
    runner.tick(host, 2 * STEP_TIME + 0.5)
    assert host.outputs[-1] == (0, 1, False)
    run_until(runner, host, 1.0, 10.0)
    assert not runner.running
    assert runner.step == 1  # back at MAIN after EOP


def test_runner_waits_for_motion_and_inputs():
    host = FakeHost()
    runner = JobRunner(1, parse_job(["JMOV P3", "WAIT IN 2,5,1", "EOP"]))
    runner.start(step_mode=False)
    runner.tick(host, 0.0)
    assert host.moves == [(False, 3, 1)]
    runner.tick(host, 1.0)
    assert runner.step == 1  # still moving
    host.moving = False
    runner.tick(host, 1.0)
    assert runner.step == 2
    runner.tick(host, 5.0)
    assert runner.step == 2 and runner.next_event(5.0) is None
    host.inputs[(2, 5)] = True
    runner.tick(host, 5.0)
    assert not runner.running and runner.step == 1  # through EOP: done


def test_goto_loops_forever_but_time_passes():
    host = FakeHost()
    runner = JobRunner(1, parse_job(["top:", "OUT 0,0,1", "GOTO top"]))
    runner.start(step_mode=False)
    now = run_until(runner, host, 0.0, 1.0)
    assert runner.running
    assert now >= 1.0
    assert len(host.outputs) == pytest.approx(1.0 / (3 * STEP_TIME), abs=2)


def test_step_mode_runs_one_step_per_start():
    host = FakeHost()
    runner = JobRunner(1, parse_job(["MAIN", "OUT 0,0,1", "EOP"]))
    runner.start(step_mode=True)
    run_until(runner, host, 0.0, 1.0)
    assert not runner.running and runner.step == 2
    runner.start(step_mode=True)
    run_until(runner, host, 1.0, 2.0)
    assert host.outputs == [(0, 0, True)] and runner.step == 3


def test_hold_restarts_the_step_and_reset_goes_to_main():
    host = FakeHost()
    runner = JobRunner(1, parse_job(["MAIN", "JMOV P1", "EOP"]))
    runner.start(step_mode=False)
    run_until(runner, host, 0.0, 0.1)
    assert host.moves and runner.step == 2
    runner.hold()
    host.moving = False
    runner.start(step_mode=False)
    runner.tick(host, 0.2)
    assert len(host.moves) == 2  # the interrupted move starts over
    runner.reset()
    assert runner.step == 1 and not runner.running


def test_a_refused_move_leaves_the_job_where_the_host_put_it():
    host = FakeHost()
    runner = JobRunner(1, parse_job(["MAIN", "JMOV P1", "EOP"]))

    def refuse(channel, linear, point, line):
        runner.hold()  # as the model does: it raises an alarm, which holds the job
        return False

    host.job_move = refuse
    runner.start(step_mode=False)
    run_until(runner, host, 0.0, 1.0)
    assert not runner.running
    assert runner.step == 2  # started again, the job retries the move
