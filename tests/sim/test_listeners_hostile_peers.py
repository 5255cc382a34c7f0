"""Hostile peers against the simulator: none of them may break it for the others.

Each test scripts a raw-socket (or raw-file) peer doing one bad thing, then checks that the
simulator still serves a well-behaved client and that the bad thing got a clear refusal.
"""

from __future__ import annotations

import json
import logging
import math
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robostar import Client
from robostar.commands.files import UploadFile
from robostar.commands.status import ReadStatus
from robostar.controller_role import ControllerSession, Request, UploadLimits
from robostar.errors import UploadIncompleteError, UsageError
from robostar.listen import warn_remote
from robostar.protocol.frame import encode_packet
from robostar.sim import SimConfig, VirtualController
from robostar.sim.control import MAX_CONNECTIONS, MAX_LINE, ControlServer, send_control
from robostar.sim.listeners import SimServer
from robostar.sim.model import Model
from robostar.sim.store import StateStore
from robostar.types import ArmForm, Point

WAIT = 5.0
AA = ReadStatus().encode()


@pytest.fixture
def sim() -> Iterator[tuple[SimServer, VirtualController]]:
    controller = VirtualController(SimConfig(speedup=20))
    with SimServer(controller) as server:
        yield server, controller


def client_of(server: SimServer) -> Client:
    return Client(server.url, timeout=1.0)


def drain(sock: socket.socket, quiet: float = 0.3) -> bytes:
    """Everything the peer sends until it has been quiet for ``quiet`` seconds (or closed)."""
    sock.settimeout(quiet)
    data = b""
    while True:
        try:
            chunk = sock.recv(65536)
        except TimeoutError:
            return data
        if not chunk:
            return data
        data += chunk


def assert_serves(server: SimServer) -> None:
    with client_of(server) as client:
        assert len(client.status()) == 3
    assert server.running and server.failure is None


# -- floods and bugs in one session ------------------------------------------------------------
def test_thousands_of_requests_in_one_write_are_taken_without_recursion() -> None:
    controller = VirtualController(SimConfig())
    controller.feed(encode_packet(AA) * 2000, 0.0)
    out = controller.output(0.0)
    assert out.startswith(
        encode_packet(ReadStatus().encode_answer(controller_status(controller))[0])
    )
    assert controller.requests == 2000


def controller_status(controller: VirtualController) -> tuple:  # type: ignore[type-arg]
    from robostar.sim.handlers import handle

    reply = handle(controller.model, ReadStatus())
    return reply.result  # type: ignore[union-attr,no-any-return]


def test_250_requests_in_one_write_leave_the_simulator_serving(
    sim: tuple[SimServer, VirtualController],
) -> None:
    server, controller = sim
    with socket.create_connection(server.address, timeout=WAIT) as flood:
        flood.sendall(encode_packet(AA) * 250)
        assert drain(flood)  # answered, not dropped
        assert_serves(server)
    assert controller.requests >= 250


class _BuggyController(VirtualController):
    """A controller whose KD handler has a bug (stands for any exception in one session)."""

    def handle(self, request: Request) -> None:
        if request.command.CODE == "KD":
            raise RuntimeError("bug in one session")
        super().handle(request)


def test_an_exception_in_one_session_drops_only_that_session(
    caplog: pytest.LogCaptureFixture,
) -> None:
    with SimServer(_BuggyController(SimConfig())) as server:
        with client_of(server) as good, socket.create_connection(server.address) as bad:
            assert len(good.status()) == 3
            bad.sendall(encode_packet(b"\xffKD"))
            bad.settimeout(WAIT)
            assert bad.recv(100) == b""  # that connection is dropped...
            assert len(good.status()) == 3  # ...and the other goes on
        assert_serves(server)
    assert "failed; dropped" in caplog.text


def test_the_second_answer_goes_to_the_peer_that_asked(
    sim: tuple[SimServer, VirtualController],
) -> None:
    server, controller = sim
    errors: list[BaseException] = []
    done = threading.Event()

    def poll() -> None:
        try:
            with client_of(server) as poller:
                while not done.is_set():
                    assert len(poller.status()) == 3
        except BaseException as exc:
            errors.append(exc)

    thread = threading.Thread(target=poll)
    thread.start()
    try:
        with client_of(server) as host:
            for on in (True, False, True, False):
                host.servo(1, on)
    finally:
        done.set()
        thread.join(WAIT)
    assert errors == []
    assert controller.executions["DB"] == 4


# -- bounded resources -------------------------------------------------------------------------
def upload(server: SimServer, lines: list[str]) -> None:
    with client_of(server) as client:
        client.execute(UploadFile(1, "BIG.JOB", 1, lines))


def job_lines(count: int) -> list[str]:
    return ["MAIN"] + [f"DELAY T=0.1 ; {i}" for i in range(count - 2)] + ["EOP"]


@pytest.mark.parametrize(
    ("limits", "says"),
    [(UploadLimits(max_lines=20), "more than 20 lines"), (UploadLimits(max_bytes=300), "bytes")],
)
def test_an_upload_past_its_limits_is_refused_with_a_reason(
    limits: UploadLimits, says: str
) -> None:
    controller = VirtualController(SimConfig(), limits=limits)
    with SimServer(controller) as server:
        with pytest.raises(UploadIncompleteError, match="0x32"):
            upload(server, job_lines(40))
        with client_of(server) as client:
            assert says in client.last_error()
        assert controller.executions["FB"] == 0
        upload(server, job_lines(5))  # a small one still goes through
        assert controller.executions["FB"] == 1


def test_clients_past_the_cap_are_refused_and_logged(caplog: pytest.LogCaptureFixture) -> None:
    with SimServer(VirtualController(SimConfig()), max_clients=2) as server:
        with client_of(server) as one, client_of(server) as two:
            assert len(one.status()) == 3 and len(two.status()) == 3
            with socket.create_connection(server.address, timeout=WAIT) as third:
                assert third.recv(10) == b""
            assert len(one.status()) == 3
        assert_serves(server)
    assert "already 2 clients" in caplog.text


def test_a_peer_that_never_reads_is_dropped_and_the_others_go_on(
    sim: tuple[SimServer, VirtualController],
) -> None:
    server, _ = sim
    with socket.create_connection(server.address) as sink:
        sink.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        for _ in range(200):
            try:
                sink.sendall(encode_packet(AA) * 200)
            except OSError:
                break
        assert_serves(server)


# -- the control socket ------------------------------------------------------------------------
@pytest.fixture
def control(sim: tuple[SimServer, VirtualController]) -> Iterator[ControlServer]:
    server, _ = sim
    with ControlServer([server]) as control_server:
        yield control_server


@pytest.mark.parametrize(
    ("line", "says"),
    [
        ("alarm 4242", "not one of"),
        ("alarm -1", "whole number"),
        ("alarm 9003 4", "channel 4"),
        ("alarm 9003 1 2", "controller 2"),
        ("input 99 0 on", "port 99"),
        ("input 0 16 on", "contact 16"),
        ("input 0 0 maybe", "on or off"),
        ("alarm 1e309", "whole number"),
        ("alarm", "expected"),
    ],
)
def test_control_commands_outside_the_simulator_are_refused(
    sim: tuple[SimServer, VirtualController], control: ControlServer, line: str, says: str
) -> None:
    server, _ = sim
    answer = send_control(control.address, line)
    assert answer.startswith("error:") and says in answer
    with client_of(server) as client:
        assert client.alarms() == ()
        assert client.alarm_history() == ()


def test_a_defined_alarm_is_raised_and_read_back(
    sim: tuple[SimServer, VirtualController], control: ControlServer
) -> None:
    server, _ = sim
    assert send_control(control.address, "alarm 9003 1") == "ok"
    with client_of(server) as client:
        assert [a.code for a in client.alarms()] == [9003]
        assert len(client.alarm_history()) == 1


def test_a_control_line_past_the_limit_is_refused(control: ControlServer) -> None:
    with socket.create_connection(control.address, timeout=WAIT) as sock:
        sock.sendall(b"x" * (MAX_LINE * 4))
        answer = drain(sock, 1.0)
    assert answer.startswith(b"error: line longer")
    assert send_control(control.address, "input 0 0 on") == "ok"


def test_control_connections_past_the_cap_are_refused(control: ControlServer) -> None:
    held = [socket.create_connection(control.address, timeout=WAIT) for _ in range(MAX_CONNECTIONS)]
    try:
        for sock in held:  # each is being served
            sock.sendall(b"input 0 0 on\n")
            assert sock.recv(100) == b"ok\n"
        with socket.create_connection(control.address, timeout=WAIT) as extra:
            assert drain(extra, 1.0).startswith(b"error: already")
    finally:
        for sock in held:
            sock.close()


# -- state files -------------------------------------------------------------------------------
def saved_snapshot(tmp_path: Path) -> dict[str, object]:
    store = StateStore(tmp_path)
    store.save(Model(SimConfig()).snapshot())
    loaded = store.load()
    assert loaded is not None
    return loaded


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (lambda s: s.update(work_timer="soon"), "work_timer"),
        (lambda s: s.update(work_timer=-1), "work_timer"),
        (lambda s: s.update(ints=[[600, 1]]), "ints[0][0]"),
        (lambda s: s.update(ints=[[1, 1.5]]), "ints[0][1]"),
        (lambda s: s.update(floats="none"), "floats"),
        (lambda s: s.update(outputs=[["yes"]]), "outputs[0][0]"),
        (lambda s: s["channels"][0].update(speed=None), "channels[0].speed"),
        (lambda s: s["channels"][0].update(points=[[0, [1, 2], 7, True]]), "channels[0].points"),
        (lambda s: s["channels"][0].update(job=5), "channels[0].job"),
        (lambda s: s.update(alarm_history=[{"at": 0}]), "alarm_history[0]"),
        (lambda s: s.pop("parameters"), "parameters"),
    ],
)
def test_a_hand_edited_state_names_the_bad_key_and_value(
    tmp_path: Path, edit: object, says: str
) -> None:
    snapshot = saved_snapshot(tmp_path)
    edit(snapshot)  # type: ignore[operator]
    with pytest.raises(UsageError, match=r"state snapshot: " + _re(says)):
        Model(SimConfig()).restore(snapshot)


def _re(text: str) -> str:
    import re

    return re.escape(text)


@pytest.mark.parametrize(
    ("raw", "says"),
    [
        (b'{"format": 1, "work_timer": NaN}', "NaN"),
        (b'{"format": 1, "work_timer": Infinity}', "Infinity"),
        (b'{"format": 1, "work_timer": \xff\xfe}', "not UTF-8"),
    ],
)
def test_a_state_file_with_nan_or_bad_bytes_is_a_clear_error(
    tmp_path: Path, raw: bytes, says: str
) -> None:
    (tmp_path / "state.json").write_bytes(raw)
    with pytest.raises(UsageError, match=says):
        VirtualController(SimConfig(), store=StateStore(tmp_path))


def test_a_nan_work_timer_never_reaches_the_model(tmp_path: Path) -> None:
    snapshot = saved_snapshot(tmp_path)
    snapshot["work_timer"] = math.nan
    with pytest.raises(UsageError, match="work_timer"):
        Model(SimConfig()).restore(snapshot)


finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    ints=st.dictionaries(st.integers(0, 499), st.integers(-(2**31), 2**31 - 1), max_size=5),
    floats=st.dictionaries(st.integers(0, 499), finite, max_size=5),
    points=st.dictionaries(
        st.integers(0, 1023),
        st.tuples(st.lists(finite, min_size=4, max_size=4), st.sampled_from(list(ArmForm))),
        max_size=5,
    ),
    speed=st.integers(0, 1000),
    clock=st.floats(0, 1e9, allow_nan=False),
)
def test_what_save_writes_load_takes_back(
    tmp_path: Path,
    ints: dict[int, int],
    floats: dict[int, float],
    points: dict[int, tuple[list[float], ArmForm]],
    speed: int,
    clock: float,
) -> None:
    model = Model(SimConfig())
    model.ints.update(ints)
    model.floats.update(floats)
    model.clock = clock
    channel = model.channel(1)
    channel.speed = speed
    for index, (axes, arm) in points.items():
        channel.points[index] = Point(tuple(axes), arm, True)
    store = StateStore(tmp_path)
    store.save(model.snapshot())
    loaded = store.load()
    assert loaded is not None
    again = Model(SimConfig())
    again.restore(loaded)
    assert again.snapshot() == json.loads(json.dumps(model.snapshot()))


# -- exposure ----------------------------------------------------------------------------------
def test_a_remote_address_is_announced_on_stderr_and_in_the_log(
    capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING):
        warn_remote("0.0.0.0", 9100, "move the robot")
    err = capsys.readouterr().err
    assert "0.0.0.0:9100" in err and "move the robot" in err
    assert "not a loopback address" in caplog.text


def test_a_loopback_address_is_not_announced(capsys: pytest.CaptureFixture[str]) -> None:
    warn_remote("127.0.0.1", 9100, "move the robot")
    assert capsys.readouterr().err == ""


def test_sessions_are_counted_across_connections(sim: tuple[SimServer, VirtualController]) -> None:
    server, controller = sim
    for _ in range(3):
        with client_of(server) as client:
            client.set_speed(1, 500)
    assert controller.executions["CB"] == 3
    assert isinstance(controller.session, ControllerSession)
