"""The status as a witness (robostar/serve/status_witness.py): while a channel rests (servo on,
in position, not running), each status read confirms its positions instead of the poller
reading them again; and never once it moved, a state change that may move it went out, the
line dropped, or ``rest_interval`` passed since the positions' last real read."""

from __future__ import annotations

import asyncio
import contextlib
from collections import Counter
from collections.abc import AsyncIterator
from typing import Any, cast

import pytest

from robostar.client.aio import AsyncClient
from robostar.commands.job import Servo
from robostar.commands.motion import Home, MoveBy
from robostar.serve import LineConfig, Who
from robostar.serve.config import ConfigError, config_from_mapping
from robostar.serve.line import Line
from robostar.serve.model import ControllerModel, Quality
from robostar.serve.status_witness import StatusWitness, rests
from robostar.sim import SimConfig, VirtualController
from robostar.transport.inproc import AsyncPeerTransport
from robostar.types import ChannelStatus, CoordSystem, MotionType, PositionKind

from .line_fakes import FaultySim, first_poll, poll_reads, wait_for

ANN = Who("ann", "api")
RESTING = ChannelStatus(servo_on=True, ready=True, in_position=True)
MOVING = ChannelStatus(servo_on=True, ready=True, running=True)
SERVO_OFF = ChannelStatus(ready=True)
ALARM = ChannelStatus(servo_on=True, alarm=True, in_position=True)


def _witness(rest_interval: float = 10.0) -> tuple[ControllerModel, StatusWitness]:
    model = ControllerModel("cell1")
    return model, StatusWitness(model, rest_interval)


def _read(model: ControllerModel, witness: StatusWitness, key: str, value: Any, at: float) -> None:
    model.set(key, value, at)
    witness.read(key, at)


def test_rest_is_servo_on_in_position_and_not_running() -> None:
    assert rests(RESTING)
    assert not rests(MOVING)
    assert not rests(SERVO_OFF)  # a SCARA's arm can be pushed by hand
    assert not rests(ChannelStatus(servo_on=True, ready=True))  # not in position: settling


def test_a_position_read_during_a_rest_is_confirmed_by_each_later_status() -> None:
    model, witness = _witness()
    witness.status({1: RESTING}, 100.0)
    _read(model, witness, "ch1/position", (1.0, 2.0), 100.1)
    witness.status({1: RESTING}, 100.2)
    assert model.get("ch1/position").at == 100.2  # type: ignore[union-attr]
    witness.status({1: RESTING}, 105.0)
    assert model.get("ch1/position").at == 105.0  # type: ignore[union-attr]
    assert witness.confirmed == 2


def test_a_position_read_before_the_rest_began_is_not_confirmed() -> None:
    # read while moving: the arm went on after the read, the rest says nothing of the value
    model, witness = _witness()
    witness.status({1: MOVING}, 100.0)
    _read(model, witness, "ch1/position", (1.0, 2.0), 100.1)
    witness.status({1: RESTING}, 100.2)
    witness.status({1: RESTING}, 100.3)
    assert model.get("ch1/position").at == 100.1  # type: ignore[union-attr]


def test_a_status_that_is_not_rest_ends_the_confirmation() -> None:
    model, witness = _witness()
    witness.status({1: RESTING}, 100.0)
    _read(model, witness, "ch1/angles", (10.0, 20.0), 100.1)
    witness.status({1: MOVING}, 100.2)
    witness.status({1: RESTING}, 100.3)  # at rest again, but somewhere else
    assert model.get("ch1/angles").at == 100.1  # type: ignore[union-attr]


@pytest.mark.parametrize("status", [SERVO_OFF, ChannelStatus(servo_on=True, ready=True)])
def test_a_channel_that_does_not_rest_is_never_confirmed(status: ChannelStatus) -> None:
    model, witness = _witness()
    witness.status({1: status}, 100.0)
    _read(model, witness, "ch1/position", (1.0, 2.0), 100.1)
    witness.status({1: status}, 100.2)
    assert model.get("ch1/position").at == 100.1  # type: ignore[union-attr]


def test_each_channel_rests_on_its_own() -> None:
    model, witness = _witness()
    witness.status({1: RESTING, 2: RESTING}, 100.0)
    _read(model, witness, "ch1/position", (1.0,), 100.1)
    _read(model, witness, "ch2/position", (2.0,), 100.1)
    witness.status({1: RESTING, 2: MOVING}, 100.2)
    assert model.get("ch1/position").at == 100.2  # type: ignore[union-attr]
    assert model.get("ch2/position").at == 100.1  # type: ignore[union-attr]


def test_nothing_is_confirmed_after_a_state_change_until_read_again(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    model, witness = _witness()
    witness.status({1: RESTING}, 100.0)
    _read(model, witness, "ch1/position", (1.0, 2.0), 100.1)
    monkeypatch.setattr("robostar.serve.status_witness.time.time", lambda: 100.15)
    witness.unsettle()  # a move went out (or the line dropped, or opened)
    witness.status({1: RESTING}, 100.12)  # began before the change, landed after: no witness
    witness.status({1: RESTING}, 100.7)  # (past SETTLE: see the next test)
    witness.status({1: RESTING}, 100.8)
    assert model.get("ch1/position").at == 100.1  # type: ignore[union-attr]
    _read(model, witness, "ch1/position", (5.0, 2.0), 100.9)  # read again: confirmed again
    witness.status({1: RESTING}, 101.0)
    assert model.get("ch1/position").at == 101.0  # type: ignore[union-attr]


def test_no_rest_starts_while_a_state_change_settles(monkeypatch: pytest.MonkeyPatch) -> None:
    # an inching step: answered at 100.0, moving from 100.1 to 100.15 (between two status
    # reads), a status at 100.05 still showing rest and a position read at 100.07 before it
    model, witness = _witness()
    monkeypatch.setattr("robostar.serve.status_witness.time.time", lambda: 100.0)
    witness.unsettle()
    witness.status({1: RESTING}, 100.05)
    _read(model, witness, "ch1/position", (1.0, 2.0), 100.07)
    witness.status({1: RESTING}, 100.25)
    witness.status({1: RESTING}, 100.45)
    assert model.get("ch1/position").at == 100.07  # type: ignore[union-attr]
    witness.status({1: RESTING}, 100.55)  # settled: a rest starts here
    assert model.get("ch1/position").at == 100.07  # type: ignore[union-attr]
    _read(model, witness, "ch1/position", (1.01, 2.0), 100.6)  # where the step ended
    witness.status({1: RESTING}, 100.65)
    assert model.get("ch1/position").at == 100.65  # type: ignore[union-attr]


def test_a_position_is_read_again_after_rest_interval_all_the_same() -> None:
    model, witness = _witness(rest_interval=2.0)
    witness.status({1: RESTING}, 100.0)
    _read(model, witness, "ch1/position", (1.0, 2.0), 100.1)
    witness.status({1: RESTING}, 102.0)
    assert model.get("ch1/position").at == 102.0  # type: ignore[union-attr]
    witness.status({1: RESTING}, 102.2)  # 2.1 s after the real read: no more
    assert model.get("ch1/position").at == 102.0  # type: ignore[union-attr]


def test_the_alarm_history_is_confirmed_while_no_channel_shows_an_alarm() -> None:
    model, witness = _witness()
    witness.status({1: SERVO_OFF, 2: SERVO_OFF}, 100.0)
    _read(model, witness, "alarm_history", ("9003",), 100.1)
    witness.status({1: SERVO_OFF, 2: SERVO_OFF}, 100.2)
    assert model.get("alarm_history").at == 100.2  # type: ignore[union-attr]
    witness.status({1: SERVO_OFF, 2: ALARM}, 100.3)
    witness.status({1: SERVO_OFF, 2: SERVO_OFF}, 100.4)
    assert model.get("alarm_history").at == 100.2  # type: ignore[union-attr]


def test_a_confirmation_tells_no_subscriber_and_keeps_a_value_that_is_not_good() -> None:
    model, witness = _witness()
    witness.status({1: RESTING}, 100.0)
    _read(model, witness, "ch1/position", (1.0, 2.0), 100.1)
    with model.subscribe() as changes:
        witness.status({1: RESTING}, 100.2)
        assert changes.pending() == 0  # the value did not change
    model.mark(Quality.STALE)
    witness.status({1: RESTING}, 100.3)
    sample = model.get("ch1/position")
    assert sample is not None and sample.quality is Quality.STALE and sample.at == 100.2


def test_rest_interval_is_a_line_setting() -> None:
    config = config_from_mapping({"lines": {"cell1": {"url": "sim://", "rest_interval": 30.0}}})
    assert config.lines[0].rest_interval == 30.0
    with pytest.raises(ConfigError, match="rest_interval"):
        LineConfig("cell1", "sim://", rest_interval=0)


# -- on a line in front of the simulator -----------------------------------------------------


def _line(sim: FaultySim, rest_interval: float = 10.0) -> Line:
    config = LineConfig(
        "cell1", "sim://", poll_interval=0.05, slow_interval=60.0, rest_interval=rest_interval
    )
    return Line(config, client_factory=sim.client)


def _sim() -> FaultySim:
    sim = FaultySim()
    sim.controller = VirtualController(SimConfig(speedup=5.0))
    return sim


async def _rest(line: Line) -> None:
    """Servo on and origin return for every channel, then a moment: the channels rest."""
    for channel in line.channels():
        await line.execute(Servo(channel, True), who=ANN, implicit_lease=True)
        await line.execute(Home(channel), who=ANN, implicit_lease=True)

    def resting() -> bool:
        statuses = [line.model.get(f"ch{n}/status") for n in line.channels()]
        return all(s is not None and s.value.origin and rests(s.value) for s in statuses)

    assert await wait_for(resting, 10.0)
    await asyncio.sleep(0.3)


def _poller_reads(seconds: float, *, at_rest: bool, rest_interval: float = 10.0) -> Counter[str]:
    """The poller's exchanges by code over ``seconds``, the robots at rest or (as the
    simulator starts) with their servos off."""

    async def main() -> Counter[str]:
        line = _line(_sim(), rest_interval)
        await line.start()
        try:
            await first_poll(line)
            if at_rest:
                await _rest(line)
            read = poll_reads(line)
            await asyncio.sleep(seconds)
            return read
        finally:
            await line.stop()

    return asyncio.run(main())


def test_at_rest_the_poller_stops_reading_positions_but_not_the_status() -> None:
    read = _poller_reads(1.0, at_rest=True)  # 20 poll cycles
    assert read["AA"] >= 10
    assert read["AC"] == 0


def test_with_the_servo_off_the_poller_reads_positions_every_cycle() -> None:
    read = _poller_reads(1.0, at_rest=False)
    assert read["AC"] >= 10


def test_at_rest_the_positions_are_read_again_every_rest_interval() -> None:
    read = _poller_reads(1.3, at_rest=True, rest_interval=0.4)
    channels = 2  # the simulator's default controller has robots on two channels
    # XY and angles of each channel, every 0.4 s (and a poll interval for the cycle to come)
    assert 2 * channels <= read["AC"] <= 4 * 2 * channels


@contextlib.asynccontextmanager
async def _resting_line(sim: FaultySim, rest_interval: float = 10.0) -> AsyncIterator[Line]:
    """A line in front of ``sim``, polled once, its robots at rest; stopped after."""
    line = _line(sim, rest_interval)
    await line.start()
    try:
        await first_poll(line)
        await _rest(line)
        yield line
    finally:
        await line.stop()


def _pendant(sim: FaultySim) -> AsyncClient:
    """A client on a session of its own: the controller's other port, or its pendant."""
    return AsyncClient(AsyncPeerTransport(sim.controller.open_session("pendant")))


def _status(line: Line, channel: int) -> ChannelStatus:
    sample = line.model.get(f"ch{channel}/status")
    assert sample is not None
    return cast(ChannelStatus, sample.value)


def _position(line: Line, channel: int) -> Any:
    sample = line.model.get(f"ch{channel}/position")
    return None if sample is None or sample.quality is not Quality.GOOD else sample.value


def test_a_motion_not_sent_through_the_line_is_seen_and_its_end_read() -> None:
    """The pendant moves the arm: the status shows it running, the poller reads the positions
    until it rests again, and the model ends at the controller's position, not the one before
    the motion."""
    sim = FaultySim()  # real time: the 60-degree move takes far longer than a poll interval

    async def main() -> None:
        async with _resting_line(sim) as line, _pendant(sim) as pendant:
            await pendant.move_by(1, (60.0, 0.0, 0.0, 0.0))
            assert await wait_for(lambda: _status(line, 1).running, 5.0)
            await pendant.wait_stopped(1)
            truth = await pendant.position(1, PositionKind.XY)
            assert await wait_for(lambda: _position(line, 1) == truth, 2.0)

    asyncio.run(main())


def test_a_motion_too_short_for_the_status_to_see_is_read_after_rest_interval() -> None:
    """The limit, bounded: a motion that may begin and end between two status reads is in the
    model at the latest ``rest_interval`` after the positions' last real read."""
    sim = _sim()

    async def main() -> None:
        async with _resting_line(sim, rest_interval=0.5) as line, _pendant(sim) as pendant:
            await pendant.move_by(1, (2.0, 0.0, 0.0, 0.0), wait=True)
            truth = await pendant.position(1, PositionKind.XY)
            assert await wait_for(lambda: _position(line, 1) == truth, 1.0)

    asyncio.run(main())


def test_a_move_through_the_line_is_read_to_its_end() -> None:
    sim = _sim()

    async def main() -> None:
        async with _resting_line(sim) as line, _pendant(sim) as other:
            move = MoveBy(1, MotionType.JOINT, CoordSystem.ANGLE, (0.0, 5.0, 0.0, 0.0))
            await line.execute(move, who=ANN, implicit_lease=True)
            await other.wait_stopped(1)  # the move is under way as BD is answered
            truth = await other.position(1, PositionKind.XY)
            assert await wait_for(lambda: _position(line, 1) == truth, 2.0)

    asyncio.run(main())
