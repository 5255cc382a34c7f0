"""The Modbus face's command handshake, with pymodbus's client as the PLC against the simulator
through the line server: a job run by number, a repeated sequence number that runs nothing, a
stop while a job runs, the controller's refusal with its flag and KD reason, the face's own
refusals (not allowed, lease held) with theirs, and every command in the audit log under the
PLC's name."""

from __future__ import annotations

import asyncio
import json
import struct
from pathlib import Path

from robostar.commands.files import UploadFile
from robostar.serve.faces.modbus.layout import HR, Outcome, Reason, channel_base
from robostar.serve.lease import Who

from .conftest import Cell, cell, text_of, until

SELECT_JOB, START_JOB, RUN_JOB, STOP_JOB, SERVO = 1, 2, 3, 4, 5
ALL = ["select_job", "start_job", "run_job", "stop_job", "servo", "speed"]
TESTER = Who("tester", "cli")


def _outcome(result: list[int]) -> Outcome:
    return Outcome(result[HR.OUTCOME - HR.WRITABLE])


def _reason(result: list[int]) -> Reason:
    return Reason(result[HR.REASON - HR.WRITABLE])


def _text(result: list[int]) -> str:
    return text_of(result[HR.TEXT - HR.WRITABLE :])


async def _waiting_job(c: Cell) -> None:
    """JOB number 7 on channel 1 waits for input 0.0 (runs until stopped); channel 1 homed."""
    c.sim.model.channel(1).origin = True
    lines = ["MAIN", "WAIT IN 0,0,1", "EOP"]
    await c.line.execute(UploadFile(1, "WAIT.JOB", 7, lines), who=TESTER, implicit_lease=True)
    c.line.lease.release(TESTER)


def _running(c: Cell) -> bool:
    return bool(c.sim.model.channel(1).running)


def test_a_job_runs_by_number_and_a_stop_ends_it(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ALL}) as c:
            await _waiting_job(c)
            result = await c.command(RUN_JOB, 1, 7, sequence=1)
            assert _outcome(result) is Outcome.DONE, _text(result)
            assert result[HR.ACCEPTED_SEQUENCE - HR.WRITABLE] == 1
            assert _running(c)
            assert str(c.sim.model.channel(1).job_name) == "WAIT.JOB"

            async def job_number_shown() -> bool:
                ch1 = await c.input_registers(channel_base(1), 4)
                return ch1[2] == 7 and ch1[0] & (1 << 5) != 0  # JOB 7, running bit

            await until(job_number_shown)
            result = await c.command(STOP_JOB, 1, sequence=2)
            assert _outcome(result) is Outcome.DONE, _text(result)
            assert not _running(c)
            records = [json.loads(line) for line in c.audit.read_text().splitlines()]
            plc = [r for r in records if r["face"] == "modbus"][1:]  # after the baseline
            assert [r["what"].split("(")[0] for r in plc] == ["SelectJob", "StartJob", "StopJob"]
            assert {r["who"] for r in plc} == {"plc"} and {r["outcome"] for r in plc} == {"ok"}

    asyncio.run(main())


def test_the_same_block_written_twice_runs_once(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ALL}) as c:
            block = [SERVO, 1, 1, 0, 0, 0, 0, 0, 0, 41]
            await c.write_block(block)
            result = await c.result(41)
            assert _outcome(result) is Outcome.DONE, _text(result)
            runs = c.sim.controller.executions.get("DB", 0)
            assert runs == 1
            for _ in range(3):
                await c.write_block(block)  # the PLC writes its block every cycle
                await c.plc.write_register(HR.SEQUENCE, 41)
            await c.line.wait_polled()
            assert c.sim.controller.executions.get("DB", 0) == runs
            block[2], block[-1] = 0, 42  # servo off: a new sequence number runs it
            await c.write_block(block)
            assert _outcome(await c.result(42)) is Outcome.DONE
            assert c.sim.controller.executions.get("DB", 0) == runs + 1

    asyncio.run(main())


def test_a_controller_refusal_carries_its_flag_and_reason(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ALL}) as c:
            result = await c.command(START_JOB, 1, sequence=7)  # no job selected
            assert _outcome(result) is Outcome.REFUSED_BY_CONTROLLER
            assert result[HR.FLAG - HR.WRITABLE] == 0x32
            assert "no job selected" in _text(result)
            result = await c.command(RUN_JOB, 1, 99, sequence=8)  # no such JOB number
            assert _outcome(result) is Outcome.REFUSED
            assert _reason(result) is Reason.NO_SUCH_JOB
            assert "99" in _text(result)

    asyncio.run(main())


def test_the_faces_refusals_say_why(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ["servo"]}) as c:
            result = await c.command(START_JOB, 1, sequence=1)
            assert _outcome(result) is Outcome.REFUSED
            assert _reason(result) is Reason.NOT_ALLOWED
            result = await c.command(SERVO, 4, 1, sequence=2)  # channel 4: no such channel
            assert _reason(result) is Reason.BAD_PARAMETER
            result = await c.command(SERVO, 1, 2, sequence=3)  # on must be 0 or 1
            assert _reason(result) is Reason.BAD_PARAMETER
            c.line.lease.acquire(TESTER)
            result = await c.command(SERVO, 1, 1, sequence=4)
            assert _outcome(result) is Outcome.REFUSED
            assert _reason(result) is Reason.LEASE_HELD
            assert "tester" in _text(result)
            assert c.sim.controller.executions.get("DB", 0) == 0
            records = [json.loads(line) for line in c.audit.read_text().splitlines()]
            refused = [r for r in records if r["face"] == "modbus"][1:]  # after the baseline
            assert len(refused) == 4
            assert all(r["outcome"].startswith("refused") for r in refused)

    asyncio.run(main())


def test_a_stop_needs_no_lease(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ALL}) as c:
            await _waiting_job(c)
            assert _outcome(await c.command(RUN_JOB, 1, 7, sequence=1)) is Outcome.DONE
            c.line.lease.release(Who("plc", "modbus"))
            c.line.lease.acquire(TESTER)  # someone else took control
            result = await c.command(STOP_JOB, 1, sequence=2)
            assert _outcome(result) is Outcome.DONE, _text(result)
            assert not _running(c)

    asyncio.run(main())


def test_globals_outputs_and_speed_are_written_by_handshake(tmp_path: Path) -> None:
    async def main() -> None:
        allow = ["global_int", "global_float", "output", "speed"]
        async with cell(tmp_path, commands={"enabled": True, "allow": allow}) as c:
            high, low = struct.unpack(">HH", struct.pack(">i", -70000))
            assert _outcome(await c.command(9, 12, high, low, sequence=1)) is Outcome.DONE
            high, low = struct.unpack(">HH", struct.pack(">f", 2.5))
            assert _outcome(await c.command(10, 3, high, low, sequence=2)) is Outcome.DONE
            assert _outcome(await c.command(8, 1, 4, 1, sequence=3)) is Outcome.DONE
            assert _outcome(await c.command(7, 1, 650, sequence=4)) is Outcome.DONE
            model = c.sim.model
            assert model.ints[12] == -70000 and model.floats[3] == 2.5
            assert model.outputs[1][4] is True
            assert c.line.model.get("ch1/speed") is not None
            await until(lambda: c.line.model.get("ch1/speed").value == 650)  # type: ignore[union-attr]

    asyncio.run(main())


def test_a_command_while_another_runs_is_busy_but_a_stop_runs(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ALL}) as c:
            c.sim.model.channel(1).origin = True
            await c.write_block([SELECT_JOB, 1, 1, 0, 0, 0, 0, 0, 0, 1])  # DC: 0.5 s to load
            result = await c.command(SERVO, 1, 1, sequence=2)
            assert _outcome(result) is Outcome.REFUSED
            assert _reason(result) is Reason.BUSY
            result = await c.command(STOP_JOB, 1, sequence=3)
            assert _outcome(result) is Outcome.DONE, _text(result)
            await until(lambda: str(c.sim.model.channel(1).job_name) == "DEMO.JOB")
            assert c.sim.controller.executions.get("DB", 0) == 0
            records = [json.loads(line) for line in c.audit.read_text().splitlines()]
            outcomes = {
                r["what"].split("(")[0]: r["outcome"] for r in records if r["face"] == "modbus"
            }
            assert outcomes["SelectJob"] == "ok" and outcomes["StopJob"] == "ok"
            assert outcomes["Servo"] == "refused: busy: sequence 1 is still running"

    asyncio.run(main())


def test_a_stop_while_a_job_is_being_selected_keeps_it_from_starting(tmp_path: Path) -> None:
    """run_job is DC then CC: a stop written while DC is on the wire must keep CC from going
    out after it, and the selection ending after the stop must not put its own number back
    in done_sequence (the PLC waits for the stop's)."""

    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ALL}) as c:
            await _waiting_job(c)
            await c.write_block([RUN_JOB, 1, 7, 0, 0, 0, 0, 0, 0, 1])
            await until(lambda: c.sim.controller.executions.get("DC", 0) == 1)
            result = await c.command(STOP_JOB, 1, sequence=2)
            assert _outcome(result) is Outcome.DONE, _text(result)
            runner = c.server.faces["modbus"].ports["cell1"].runner  # type: ignore[attr-defined]
            await until(lambda: not runner.tasks)  # run_job has ended too
            assert c.sim.controller.executions.get("CC", 0) == 0
            assert not _running(c)
            result = await c.result(2)
            assert result[HR.ACCEPTED_SEQUENCE - HR.WRITABLE] == 2
            assert _outcome(result) is Outcome.DONE
            records = [json.loads(line) for line in c.audit.read_text().splitlines()]
            (start,) = [r for r in records if r["what"].startswith("modbus run_job")]
            assert start["outcome"].startswith("refused: a stop came")  # in the audit log

    asyncio.run(main())


def test_a_command_taken_just_before_a_stop_is_not_sent_after_it(tmp_path: Path) -> None:
    """Two writes in one go (servo on, then a stop) before the first has begun to run: the
    servo must not go out after the stop."""

    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ALL}) as c:
            runner = c.server.faces["modbus"].ports["cell1"].runner  # type: ignore[attr-defined]
            runner.submit([SERVO, 1, 1, 0, 0, 0, 0, 0, 0, 1])
            runner.submit([STOP_JOB, 1, 0, 0, 0, 0, 0, 0, 0, 2])  # same tick: servo not begun
            await until(lambda: not runner.tasks)
            assert c.sim.controller.executions.get("DB", 0) == 0
            assert c.sim.controller.executions.get("CD", 0) == 1
            assert _outcome(await c.result(2)) is Outcome.DONE

    asyncio.run(main())


def test_the_first_sequence_after_a_start_is_not_run(tmp_path: Path) -> None:
    """A PLC that writes its block every cycle writes the last command again after the face
    restarts: that block must not run a second time."""

    async def main() -> None:
        options = {"commands": {"enabled": True, "allow": ALL}}
        async with cell(tmp_path, prime=False, **options) as c:
            result = await c.command(SERVO, 1, 1, sequence=9)
            assert _outcome(result) is Outcome.REFUSED
            assert _reason(result) is Reason.RESTARTED
            assert "write a new one" in _text(result)
            assert c.sim.controller.executions.get("DB", 0) == 0
            await c.write_block([SERVO, 1, 1, 0, 0, 0, 0, 0, 0, 9])  # again: nothing
            assert _outcome(await c.command(SERVO, 1, 1, sequence=10)) is Outcome.DONE
            assert c.sim.controller.executions.get("DB", 0) == 1

    asyncio.run(main())


def test_the_plc_homes_a_channel(tmp_path: Path) -> None:
    """A cell's start: servo on, then origin return, with nobody at the teach pendant."""

    async def main() -> None:
        allow = ["servo", "home", "stop_homing"]
        async with cell(tmp_path, commands={"enabled": True, "allow": allow}) as c:
            assert not c.sim.model.channel(1).origin
            assert _outcome(await c.command(SERVO, 1, 1, sequence=1)) is Outcome.DONE
            result = await c.command(14, 1, sequence=2)  # home
            assert _outcome(result) is Outcome.DONE, _text(result)

            async def origin_shown() -> bool:
                bits = (await c.plc.read_discrete_inputs(0, count=8)).bits
                return bool(bits[1])  # ch1.origin

            await until(origin_shown, timeout=30)

    asyncio.run(main())


def test_a_lost_answer_is_published_as_outcome_unknown(tmp_path: Path) -> None:
    async def main() -> None:
        async with cell(tmp_path, commands={"enabled": True, "allow": ALL}) as c:
            c.sim.lose_answer_of = "CB"
            result = await c.command(7, 1, 400, sequence=1)  # speed
            assert _outcome(result) is Outcome.OUTCOME_UNKNOWN
            assert "outcome is unknown" in _text(result)
            assert c.sim.model.channel(1).speed == 400  # it ran: the PLC must check, not resend

    asyncio.run(main())
