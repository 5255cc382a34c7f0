"""The VirtualController as a byte peer: time, two-phase answers, reliability and its store."""

from __future__ import annotations

import json

import pytest
from sim_harness import Harness

from robostar.commands.control import SetSpeed
from robostar.commands.files import DownloadFile, UploadFile
from robostar.commands.io import SetOutput
from robostar.commands.job import SelectJob, Servo
from robostar.commands.motion import Home, Move
from robostar.commands.status import ReadStatus
from robostar.commands.variables import WriteGlobalFloat, WriteGlobalInt
from robostar.errors import UsageError
from robostar.protocol.frame import encode_packet
from robostar.protocol.link import AnswerReceived, HostLink, State
from robostar.sim import Model, SimConfig, VirtualController
from robostar.sim.alarms import AlarmCode
from robostar.transport.peer import BytePeer
from robostar.types import CoordSystem, MotionType


def test_it_is_a_byte_peer():
    assert isinstance(VirtualController(), BytePeer)


def test_model_time_runs_speedup_times_faster():
    h = Harness(speedup=20.0)
    h.ok(Home(1))
    h.wait(0.1)  # 2 model seconds: the 2 s homing is done
    assert h.model.clock == pytest.approx(2.0)
    assert h.ok(ReadStatus())[0].origin


def test_next_deadline_is_the_end_of_the_motion_in_real_time():
    h = Harness(speedup=10.0)
    h.ok(Home(1))
    assert h.controller.next_deadline() == pytest.approx(h.now + 2.0 / 10.0)


def test_an_idle_controller_has_no_deadline():
    assert Harness().controller.next_deadline() is None


def test_dc_first_answer_comes_at_once_and_the_second_after_loading():
    h = Harness(speedup=1.0)
    h.ok(Home(1))
    h.wait(2.1)
    command = SelectJob(1, "DEMO.JOB")
    events = h.host.send_request(command.encode(), command.SHAPE, h.now)
    start = h.now
    answers = []
    while len(answers) < 2:
        events, _ = h._pump()
        answers += [(h.now, e.data) for e in events if isinstance(e, AnswerReceived)]
        if not events:
            h._step_clock()
    (t1, first), (t2, second) = answers
    assert (t1, first) == (start, b"\x3001")  # expected wait: 1 s, honest
    assert second == b"\x30"
    assert t2 - start == pytest.approx(0.5)  # the job's load time


def test_a_new_request_drops_a_pending_second_answer_but_not_the_work():
    h = Harness(speedup=1.0)
    # This is about the controller; without the host's quiet gap after its RST, the next
    # request reaches the controller while the servo is still coming on.
    h.host = HostLink(timeout=2.0, resync_gap=0)
    command = Servo(1, True)
    h.host.send_request(command.encode(), command.SHAPE, h.now)
    h.wait(0.05)  # first answer sent and ACKed; the controller works on
    assert h.controller.link.state is State.WORKING
    h.host.abort(h.now)  # the host gives up: RST
    h._pump()
    assert h.ok(ReadStatus())[0].servo_on is False
    h.wait(0.5)
    assert h.ok(ReadStatus())[0].servo_on is True
    assert h.controller.link.state is State.LISTEN


def test_a_nakked_answer_is_resent_not_carried_out_again():
    h = Harness()
    h.controller.feed(encode_packet(SetOutput(0, 1, True).encode()), h.now)
    answer = h.controller.output(h.now)
    assert answer == encode_packet(b"\x30")
    for _ in range(2):
        h.controller.feed(b"\x15", h.now)  # NAK
        assert h.controller.output(h.now) == answer
    h.controller.feed(b"\x06", h.now)
    assert h.controller.executions["GC"] == 1
    assert h.controller.link.state is State.LISTEN


def test_a_lost_ack_makes_the_controller_resend_after_the_real_timeout():
    h = Harness(speedup=100.0, ack_timeout=0.5)
    h.controller.feed(encode_packet(WriteGlobalInt(3, 5).encode()), h.now)
    answer = h.controller.output(h.now)
    assert h.controller.next_deadline() == pytest.approx(h.now + 0.5)
    h.now += 0.5
    assert h.controller.output(h.now) == answer
    h.controller.feed(b"\x06", h.now)
    assert h.controller.executions["GW"] == 1


def test_only_state_changing_commands_are_counted():
    h = Harness()
    h.ok(ReadStatus())
    h.ok(SetSpeed(1, 10))
    h.ok(SetSpeed(1, 20))
    h.fail(Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((1.0, 2.0, 3.0, 4.0),)))
    assert h.controller.executions == {"CB": 2}


# -- the store ---------------------------------------------------------------------------------
class FakeStore:
    def __init__(self, snapshot=None):
        self.snapshot = snapshot
        self.saves: list[tuple[State, dict]] = []
        self.controller: VirtualController | None = None

    def load(self):
        return self.snapshot

    def save(self, snapshot):
        json.dumps(snapshot)  # must be JSON-ready
        state = self.controller.link.state if self.controller else State.LISTEN
        self.saves.append((state, snapshot))
        self.snapshot = snapshot


def test_every_change_is_saved_before_its_answer_is_sent():
    store = FakeStore()
    h = Harness(store=store)
    store.controller = h.controller
    h.ok(ReadStatus())
    assert store.saves == []
    h.ok(WriteGlobalInt(1, 42))
    h.ok(SetOutput(0, 2, True))
    h.ok(UploadFile(1, "RS.JOB", 3, ["MAIN", "EOP"]))
    states = [state for state, _ in store.saves]
    assert states == [State.HANDLING, State.HANDLING, State.UPLOAD_HANDLING]
    last = store.saves[-1][1]
    assert last["ints"] == [[1, 42]]
    assert last["outputs"][0][2] == 1


def test_a_store_is_loaded_at_start():
    first = FakeStore()
    h = Harness(store=first)
    h.ok(WriteGlobalFloat(9, 1.5))
    h.ok(UploadFile(2, "KEEP.JOB", 4, ["MAIN", "EOP"]))
    again = Harness(store=FakeStore(first.snapshot))
    assert again.model.floats == {9: 1.5}
    assert again.ok(DownloadFile(2, "KEEP.JOB")).lines == ("MAIN", "EOP")


def test_alarms_raised_by_refusals_are_saved_too():
    store = FakeStore()
    h = Harness(store=store)
    h.fail(Move(1, MotionType.JOINT, CoordSystem.ANGLE, ((1.0, 2.0, 3.0, 4.0),)))
    history = store.snapshot["alarm_history"]
    assert [entry["code"] for entry in history] == [AlarmCode.RUN_FAIL]


# -- snapshot and restore ----------------------------------------------------------------------
def test_snapshot_round_trip_keeps_what_a_controller_keeps():
    config = SimConfig(speedup=50.0)
    h = Harness(config)
    h.ok(Home(1))
    h.wait_model(2.1)
    h.ok(SelectJob(1, "DEMO.JOB"))
    h.ok(SetSpeed(2, 123))
    h.ok(SetOutput(2, 7, True))
    h.ok(WriteGlobalInt(0, 7))
    h.model.raise_alarm(1153, 1)
    h.model.public_parameters[3] = "FDBUS: CC-LINK"
    snapshot = json.loads(json.dumps(h.model.snapshot()))
    model = Model(config)
    model.restore(snapshot)
    assert model.snapshot() == snapshot
    assert str(model.channel(1).job_name) == "DEMO.JOB"
    assert model.channel(2).speed == 123
    assert model.outputs[2][7] is True
    assert model.alarms.records()[0].code == 1153
    assert model.alarms.alarms() == ()  # current alarms do not survive a power cycle
    assert model.clock == pytest.approx(h.model.clock)
    assert model.public_parameters[3] == "FDBUS: CC-LINK"


def test_restore_rederives_what_the_configuration_says():
    snapshot = Model(SimConfig()).snapshot()
    model = Model(SimConfig(auto_servo_on=False, name="OTHER"))
    model.restore(snapshot)
    assert model.public_parameters[8] == "AUTO SVON: DIS"
    assert model.public_parameters[54] == "NAME: OTHER"


@pytest.mark.parametrize(
    "snapshot",
    [[], {"format": 99}, {"format": 1}, {"format": 1, "work_timer": "x", "channels": []}],
)
def test_a_bad_snapshot_is_a_usage_error_and_changes_nothing(snapshot):
    model = Model()
    before = model.snapshot()
    with pytest.raises(UsageError, match="state snapshot"):
        model.restore(snapshot)
    assert model.snapshot() == before
