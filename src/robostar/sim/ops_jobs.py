"""Job operations: select, start, stop, reset, mode and step, and the runner's host side."""

from __future__ import annotations

from collections.abc import Callable

from robostar.protocol.fields import FileName
from robostar.sim.alarms import AlarmCode
from robostar.sim.filesystem import StoredJob
from robostar.sim.jobs import JobRunner, JobSyntaxError, parse_job
from robostar.sim.ops_motion import MotionOps
from robostar.sim.state import (
    Channel,
    Refused,
)
from robostar.types import (
    JobMode,
    MotionType,
)

__all__ = ["JobOps"]

JOB_LOAD_TIME = 0.5
JOB_RESET_TIME = 0.2


class JobOps(MotionOps):
    """DC, CC, CD, CE, EA, ED; and the host side of the job runner (JobHost)."""

    # -- jobs ----------------------------------------------------------------------------------
    def _load(self, ch: Channel, name: FileName) -> tuple[StoredJob, JobRunner]:
        stored = ch.files.get(name)
        if not isinstance(stored, StoredJob):
            raise Refused(f"no file {name} on channel {ch.number}")
        try:
            program = parse_job(stored.lines)
        except JobSyntaxError as exc:
            raise self._alarm_refusal(
                AlarmCode.SYNTAX_ERROR,
                ch,
                f"{stored.name} line {exc.line}: {exc.message}",
                f"{stored.name.stem} L{exc.line}",
            ) from None
        return stored, JobRunner(ch.number, program)

    def select_job(self, number: int, name: FileName) -> tuple[float, Callable[[], None]]:
        """DC: check, then load the job after JOB_LOAD_TIME."""
        ch = self.channel(number)
        if ch.running:
            raise Refused(f"channel {ch.number} is busy (moving or running a job)")
        if not ch.origin:
            raise self._alarm_refusal(
                AlarmCode.RUN_FAIL,
                ch,
                f"origin return (BA) is not done on channel {ch.number}",
                "DC no origin",
            )
        stored, runner = self._load(ch, name)

        def finish() -> None:
            ch.job = runner
            ch.job_name = stored.name
            self.changed()

        return JOB_LOAD_TIME, finish

    def start_job(self, number: int) -> None:
        ch = self.channel(number)
        if ch.job is None:
            raise Refused(f"no job selected on channel {ch.number}; select one with DC")
        if self.alarms.on_channel(ch.number):
            raise Refused(f"channel {ch.number} has an alarm; reset it with CG first")
        if ch.running:
            raise Refused(f"channel {ch.number} is busy (moving or running a job)")
        if not ch.origin:
            raise self._alarm_refusal(
                AlarmCode.RUN_FAIL,
                ch,
                f"origin return (BA) is not done on channel {ch.number}",
                "CC no origin",
            )
        if ch.cfg.can_move and not ch.servo:
            if not self.config.auto_servo_on:
                raise Refused(
                    f"servo off on channel {ch.number}: AUTO SERVO ON is DIS, "
                    "turn it on with DB first"
                )
            ch.servo = True
        ch.job.start(step_mode=ch.mode is JobMode.STEP)

    def stop_job(self, number: int) -> None:
        ch = self.channel(number)
        if ch.job is not None and ch.job.running:
            ch.halt()

    def reset_job(self, number: int) -> tuple[float, Callable[[], None]]:
        ch = self.channel(number)
        if ch.servo:
            raise Refused(f"servo is on (channel {ch.number}); CE needs the servo off")
        job = ch.job
        if job is None:
            raise Refused(f"no job selected on channel {ch.number}; select one with DC")
        return JOB_RESET_TIME, job.reset

    def set_job_mode(self, number: int, mode: JobMode) -> None:
        ch = self.channel(number)
        if ch.running:
            raise Refused(f"channel {ch.number} RUN bit is on; EA needs it off")
        ch.mode = mode

    def job_step(self, number: int) -> int:
        job = self.channel(number).job
        return job.step if job is not None else 0

    # JobHost: what the runner asks of the model.
    def _tick_jobs(self) -> None:
        for ch in self.channels:
            if ch.job is not None and ch.job.running:
                ch.job.tick(self, self.clock)

    def job_move(self, channel: int, linear: bool, point: int, line: int) -> bool:
        ch = self.channel(channel)
        stem = ch.job_name.stem if ch.job_name is not None else ""
        where = f"{stem} L{line}"
        if not ch.cfg.can_move:
            self.raise_alarm(AlarmCode.RUN_FAIL, ch.number, f"{where} no robot")
            return False
        if ch.speed == 0:
            self.raise_alarm(AlarmCode.RUN_FAIL, ch.number, f"{where} speed 0")
            return False
        try:
            target = self._pnt_point(ch, FileName(stem, "PNT"), point, where)
            motion = MotionType.LINEAR if linear else MotionType.JOINT
            ch.path = self._plan(ch, motion, [target], where)
        except Refused:
            return False
        ch.path_t = 0.0
        return True

    def job_moving(self, channel: int) -> bool:
        return self.channel(channel).path is not None

    def job_output(self, channel: int, port: int, contact: int, on: bool, line: int) -> bool:
        if port > self.io_ports(output=True):
            ch = self.channel(channel)
            where = f"{ch.job_name.stem if ch.job_name else ''} L{line}"
            self.raise_alarm(AlarmCode.RUN_FAIL, channel, f"{where} OUT {port}")
            return False
        self.outputs[port][contact] = on
        self.changed()
        return True

    def job_input(self, port: int, contact: int) -> bool:
        return self.inputs[port][contact]
