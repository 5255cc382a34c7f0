"""Tests of the simulator servers: real sockets on 127.0.0.1, a real pseudo-terminal, serve().

Nothing here asserts how fast anything happens: every wait is a generous upper bound on a
condition that must come true.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import serial

from robostar.commands.control import ReadSpeed, SetSpeed
from robostar.commands.status import ReadStatus
from robostar.controller_role import ControllerSession
from robostar.errors import PortError, UsageError
from robostar.protocol.frame import ACK, NAK, FrameDecoder, Packet, encode_packet
from robostar.protocol.link import (
    After,
    AnswerReceived,
    ControllerLink,
    ExchangeComplete,
    ExchangeFailed,
    FailReason,
    HostLink,
    LinkEvent,
    RequestReceived,
)
from robostar.protocol.packets import Shape
from robostar.sim import SimConfig, VirtualController
from robostar.sim.faults import FaultInjector, FaultKind, parse_fault
from robostar.sim.listeners import (
    PeerHost,
    PtyServer,
    SimServer,
    build_lines,
    parse_listen,
    serve,
)
from robostar.sim.pacing import PacedPeer

WAIT = 10.0
"""Upper bound for anything to happen; only reached when a test fails."""
AA = ReadStatus().encode()
CANNED = b"\x30\xb5\x80\x80"

needs_pty = pytest.mark.skipif(os.name != "posix", reason="pseudo-terminals need POSIX")


class Canned:
    """A byte peer on the real controller link answering every request with CANNED."""

    def __init__(self, *, ack_timeout: float = 2.0) -> None:
        self.link = ControllerLink(timeout=ack_timeout)
        self.requests: list[bytes] = []

    def feed(self, data: bytes, now: float) -> None:
        for event in self.link.receive_data(data, now):
            if isinstance(event, RequestReceived):
                self.requests.append(event.data)
                self.link.send_answer([CANNED], After.DONE, now)

    def output(self, now: float) -> bytes:
        self.link.handle_timeout(now)
        return self.link.data_to_send()

    def next_deadline(self) -> float | None:
        return self.link.next_deadline()


class HostSide:
    """The host end of a byte stream, running the real host link on the real clock."""

    def __init__(self, write: Callable[[bytes], None], read: Callable[[float], bytes]) -> None:
        self.write = write
        self.read = read

    @classmethod
    def tcp(cls, sock: socket.socket) -> HostSide:
        def read(timeout: float) -> bytes:
            sock.settimeout(timeout)
            try:
                data = sock.recv(4096)
            except TimeoutError:
                return b""
            if not data:
                raise ConnectionError("the server closed the connection")
            return data

        return cls(sock.sendall, read)

    @classmethod
    def serial(cls, port: serial.Serial) -> HostSide:
        def read(timeout: float) -> bytes:
            port.timeout = timeout
            return port.read(max(1, port.in_waiting))

        def write(data: bytes) -> None:
            port.write(data)

        return cls(write, read)

    def exchange(self, data: bytes, shape: Shape = Shape.SINGLE) -> list[LinkEvent]:
        host = HostLink(timeout=3.0)
        events = host.send_request(data, shape, time.monotonic())
        end = time.monotonic() + WAIT
        while time.monotonic() < end:
            out = host.data_to_send()
            if out:
                self.write(out)
            if any(isinstance(e, ExchangeComplete | ExchangeFailed) for e in events):
                return events
            chunk = self.read(0.05)
            now = time.monotonic()
            if chunk:
                events += host.receive_data(chunk, now)
            events += host.handle_timeout(now)
        raise AssertionError(f"no end to the exchange: {events}")

    def answer(self, data: bytes) -> bytes:
        """The data of the single answer to ``data``; the exchange must complete."""
        events = self.exchange(data)
        assert isinstance(events[-1], ExchangeComplete), events
        answers = [e.data for e in events if isinstance(e, AnswerReceived)]
        assert len(answers) == 1, events
        return answers[0]


def wait_for(condition: Callable[[], bool], what: str) -> None:
    end = time.monotonic() + WAIT
    while not condition():
        if time.monotonic() > end:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.01)


def recv_exactly(sock: socket.socket, n: int) -> bytes:
    sock.settimeout(WAIT)
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            break
        data += chunk
    return data


@pytest.fixture
def canned_server() -> Iterator[tuple[SimServer, Canned]]:
    peer = Canned()
    with SimServer(peer) as server:
        yield server, peer


def connect(server: SimServer) -> socket.socket:
    return socket.create_connection(server.address, timeout=WAIT)


# -- TCP ---------------------------------------------------------------------------------------
def test_the_server_binds_loopback_and_reports_its_address(
    canned_server: tuple[SimServer, Canned],
) -> None:
    server, _ = canned_server
    host, port = server.address
    assert host == "127.0.0.1"
    assert port > 0
    assert server.url == f"tcp://127.0.0.1:{port}"
    assert server.endpoints == [server.url]


def test_two_clients_in_turn_each_get_their_answer(
    canned_server: tuple[SimServer, Canned],
) -> None:
    server, peer = canned_server
    for _ in range(2):
        with connect(server) as sock:
            assert HostSide.tcp(sock).answer(AA) == CANNED
    assert peer.requests == [AA, AA]


def test_the_answer_goes_to_the_client_that_asked(
    canned_server: tuple[SimServer, Canned],
) -> None:
    server, _ = canned_server
    with connect(server) as first, connect(server) as second:
        wait_for(lambda: server.clients == 2, "two clients")
        assert HostSide.tcp(first).answer(AA) == CANNED
        # The second client's stream holds nothing of the first one's exchange.
        second.sendall(encode_packet(AA))
        assert recv_exactly(second, len(encode_packet(CANNED))) == encode_packet(CANNED)


def test_a_client_leaving_mid_exchange_does_not_wedge_the_controller(
    canned_server: tuple[SimServer, Canned],
) -> None:
    server, peer = canned_server
    with connect(server) as quitter:
        quitter.sendall(encode_packet(AA))
        recv_exactly(quitter, 2)  # the answer has started; leave without ACKing it
    with connect(server) as sock:
        assert HostSide.tcp(sock).answer(AA) == CANNED
    assert peer.requests == [AA, AA]


@pytest.mark.parametrize("cut", [1, 3, len(encode_packet(AA)) - 1])
def test_a_client_leaving_mid_packet_leaves_a_clean_line(
    canned_server: tuple[SimServer, Canned], cut: int
) -> None:
    server, peer = canned_server
    with connect(server) as quitter:
        quitter.sendall(encode_packet(AA)[:cut])
        wait_for(lambda: server.clients == 1, "the first client")
    wait_for(lambda: server.clients == 0, "the first client to leave")
    with connect(server) as sock:
        sock.sendall(encode_packet(AA))
        # The very first byte is the answer's STX: no NAK for the fragment reaches this client.
        assert recv_exactly(sock, len(encode_packet(CANNED))) == encode_packet(CANNED)
        sock.sendall(bytes((ACK,)))
    assert peer.requests == [AA]


def test_the_controller_timers_run_without_any_client_traffic() -> None:
    peer = Canned(ack_timeout=0.2)
    answer = encode_packet(CANNED)
    with SimServer(peer) as server, connect(server) as sock:
        sock.sendall(encode_packet(AA))
        # Never ACKed, the answer comes again when the controller's ACK timeout fires.
        assert recv_exactly(sock, 2 * len(answer)) == answer * 2


def test_a_disconnect_fault_closes_the_connection_and_the_next_one_works() -> None:
    injector = FaultInjector(Canned())
    injector.schedule(FaultKind.DISCONNECT, at_byte=3)
    with SimServer(injector) as server:
        with connect(server) as sock:
            sock.sendall(encode_packet(AA))
            assert recv_exactly(sock, 100) == encode_packet(CANNED)[:3]
        with connect(server) as sock:
            assert HostSide.tcp(sock).answer(AA) == CANNED
    assert injector.total(FaultKind.DISCONNECT) == 1


def test_a_failing_peer_stops_the_server_and_clients_see_the_end() -> None:
    class Broken(Canned):
        def feed(self, data: bytes, now: float) -> None:
            raise RuntimeError("model bug")

    with SimServer(Broken()) as server, connect(server) as sock:
        sock.sendall(encode_packet(AA))
        assert recv_exactly(sock, 1) == b""
        wait_for(lambda: not server.running, "the server thread to stop")
        assert isinstance(server.failure, RuntimeError)


@pytest.mark.parametrize("host", ["0.0.0.0", "::", "192.0.2.1", "example.invalid", ""])
def test_a_non_loopback_address_is_refused(host: str) -> None:
    with pytest.raises(UsageError, match="host"):
        SimServer(Canned(), host)


def test_a_remote_address_is_allowed_only_when_asked() -> None:
    server = SimServer(Canned(), "0.0.0.0", allow_remote=True)  # built, never started
    server.close()


@pytest.mark.parametrize("port", [-1, 65536, True, "9100"])
def test_a_bad_port_is_refused(port: object) -> None:
    with pytest.raises(UsageError, match="port"):
        SimServer(Canned(), port=port)  # type: ignore[arg-type]


def test_a_port_in_use_is_a_port_error(canned_server: tuple[SimServer, Canned]) -> None:
    server, _ = canned_server
    other = SimServer(Canned(), port=server.address[1])
    with pytest.raises(PortError, match=str(server.address[1])):
        other.start()
    other.close()


def test_a_non_peer_is_refused() -> None:
    with pytest.raises(UsageError, match="peer"):
        PeerHost(object())  # type: ignore[arg-type]


def test_endpoints_cannot_be_added_after_start(canned_server: tuple[SimServer, Canned]) -> None:
    server, _ = canned_server
    with pytest.raises(UsageError, match="before start"):
        server.listen_tcp()


def test_close_is_idempotent_and_frees_the_port() -> None:
    server = SimServer(Canned()).start()
    address = server.address
    server.close()
    server.close()
    with pytest.raises(OSError):
        socket.create_connection(address, timeout=WAIT).close()


@pytest.mark.parametrize(
    ("text", "want"),
    [
        ("127.0.0.1:9100", ("127.0.0.1", 9100)),
        ("localhost:0", ("localhost", 0)),
        ("[::1]:9200", ("::1", 9200)),
        ("9300", ("127.0.0.1", 9300)),
    ],
)
def test_listen_addresses_parse(text: str, want: tuple[str, int]) -> None:
    assert parse_listen(text) == want


@pytest.mark.parametrize("text", ["", "127.0.0.1", "host:port", "127.0.0.1:70000", "[::1]9100"])
def test_bad_listen_addresses_are_refused(text: str) -> None:
    with pytest.raises(UsageError, match=r"listen|port"):
        parse_listen(text)


# -- the virtual controller over TCP and a pseudo-terminal ----------------------------------
def test_the_virtual_controller_answers_over_tcp() -> None:
    with SimServer(VirtualController(SimConfig())) as server, connect(server) as sock:
        data = HostSide.tcp(sock).answer(AA)
    statuses = ReadStatus().decode_answer([data])
    assert len(statuses) == 3


@needs_pty
def test_the_pty_serves_a_canned_peer_to_pyserial() -> None:
    with PtyServer(Canned()) as server:
        assert server.endpoints == [server.device_path]
        with serial.Serial(server.device_path, timeout=WAIT) as port:
            assert HostSide.serial(port).answer(AA) == CANNED


@needs_pty
def test_the_virtual_controller_answers_aa_over_a_pty() -> None:
    with PtyServer(VirtualController(SimConfig())) as server:
        with serial.Serial(server.device_path, baudrate=115200, timeout=WAIT) as port:
            port.write(encode_packet(AA))
            decoder = FrameDecoder()
            events: list[object] = []
            while not events:
                chunk = port.read(1)
                assert chunk, "no answer on the pty"
                events += decoder.feed(chunk)
            port.write(bytes((ACK,)))
        (packet,) = events
        assert isinstance(packet, Packet)
        statuses = ReadStatus().decode_answer([packet.data])
        assert len(statuses) == 3
        # The device can be opened again by the next program.
        with serial.Serial(server.device_path, timeout=WAIT) as port:
            assert HostSide.serial(port).answer(AA) == packet.data


# -- serve() -----------------------------------------------------------------------------------
class Serving:
    """serve() on a thread, stopped through its ``stop`` event."""

    def __init__(self, **options: object) -> None:
        self.stop = threading.Event()
        self.ready = threading.Event()
        self.endpoints: list[str] = []
        self.error: BaseException | None = None

        def on_ready(endpoints: list[str]) -> None:
            self.endpoints = endpoints
            self.ready.set()

        def run() -> None:
            try:
                serve(on_ready=on_ready, stop=self.stop, **options)  # type: ignore[arg-type]
            except BaseException as exc:
                self.error = exc
                self.ready.set()

        self.thread = threading.Thread(target=run, daemon=True)
        self.thread.start()
        assert self.ready.wait(WAIT), "serve() never became ready"
        if self.error is not None:
            raise self.error

    def close(self) -> None:
        self.stop.set()
        self.thread.join(WAIT)
        assert not self.thread.is_alive()


def tcp_side(url: str) -> tuple[socket.socket, HostSide]:
    host, port = parse_listen(url.removeprefix("tcp://"))
    sock = socket.create_connection((host, port), timeout=WAIT)
    return sock, HostSide.tcp(sock)


@needs_pty
def test_serve_runs_independent_controllers_each_on_tcp_and_a_pty(tmp_path: Path) -> None:
    serving = Serving(
        config=SimConfig(), listen="127.0.0.1:0", pty=True, count=2, state_dir=tmp_path
    )
    try:
        tcp1, pty1, tcp2, pty2 = serving.endpoints
        assert tcp1.startswith("tcp://127.0.0.1:")
        assert tcp2.startswith("tcp://127.0.0.1:")
        assert pty1.startswith("/") and pty2.startswith("/") and pty1 != pty2
        sock1, side1 = tcp_side(tcp1)
        sock2, side2 = tcp_side(tcp2)
        with sock1, sock2:
            side1.answer(SetSpeed(1, 250).encode())
            side2.answer(SetSpeed(1, 600).encode())
            assert ReadSpeed(1).decode_answer([side1.answer(ReadSpeed(1).encode())]) == 250
            assert ReadSpeed(1).decode_answer([side2.answer(ReadSpeed(1).encode())]) == 600
        with serial.Serial(pty1, timeout=WAIT) as port:
            got = HostSide.serial(port).answer(ReadSpeed(1).encode())
            assert ReadSpeed(1).decode_answer([got]) == 250
    finally:
        serving.close()
    assert (tmp_path / "ctrl-1" / "state.json").is_file()
    assert (tmp_path / "ctrl-2" / "state.json").is_file()


def test_serve_keeps_state_across_runs(tmp_path: Path) -> None:
    first = Serving(listen="127.0.0.1:0", state_dir=tmp_path)
    try:
        sock, side = tcp_side(first.endpoints[0])
        with sock:
            side.answer(SetSpeed(2, 321).encode())
    finally:
        first.close()
    assert (tmp_path / "state.json").is_file()
    second = Serving(listen="127.0.0.1:0", state_dir=tmp_path)
    try:
        sock, side = tcp_side(second.endpoints[0])
        with sock:
            assert ReadSpeed(2).decode_answer([side.answer(ReadSpeed(2).encode())]) == 321
    finally:
        second.close()


def test_serve_puts_controllers_on_consecutive_ports() -> None:
    for _ in range(5):  # another program may hold the port after ours; try elsewhere
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            base = probe.getsockname()[1]
        if base >= 65535:
            continue
        try:
            serving = Serving(listen=f"127.0.0.1:{base}", count=2)
        except PortError:
            continue
        try:
            assert serving.endpoints == [f"tcp://127.0.0.1:{base}", f"tcp://127.0.0.1:{base + 1}"]
        finally:
            serving.close()
        return
    pytest.fail("no two free consecutive ports found")


def test_serve_wires_the_faults_in() -> None:
    serving = Serving(listen="127.0.0.1:0", faults=["nak*4"])
    try:
        sock, side = tcp_side(serving.endpoints[0])
        with sock:
            events = side.exchange(AA)
            assert isinstance(events[-1], ExchangeFailed)
            assert events[-1].reason is FailReason.NAK_LIMIT
            assert side.answer(AA)  # the storm is over
    finally:
        serving.close()


def test_serve_with_line_timing_still_answers() -> None:
    serving = Serving(listen="127.0.0.1:0", baud=9600, turnaround=0.002)
    try:
        sock, side = tcp_side(serving.endpoints[0])
        with sock:
            assert len(ReadStatus().decode_answer([side.answer(AA)])) == 3
            assert len(ReadStatus().decode_answer([side.answer(AA)])) == 3
    finally:
        serving.close()


def test_serve_stacks_line_timing_outside_the_faults() -> None:
    lines = build_lines(
        SimConfig(seed=5),
        1,
        store=None,
        faults=[parse_fault("corrupt:0.1")],
        baud=9600,
        turnaround=0.002,
    )
    peer = lines.open_session("test")
    assert isinstance(peer, PacedPeer)
    assert (peer.baud, peer.turnaround) == (9600, 0.002)
    assert isinstance(peer.peer, FaultInjector)
    assert peer.peer.seed == 6
    assert isinstance(peer.peer.peer, ControllerSession)
    assert peer.peer.peer.backend is lines.controller


@pytest.mark.parametrize(
    ("options", "says"),
    [
        ({"count": 0}, "count"),
        ({"listen": None}, "nothing to serve"),
        ({"listen": "0.0.0.0:9100"}, "loopback"),
        ({"listen": "127.0.0.1:65535", "count": 2}, "65535"),
        ({"faults": ["explode"]}, "fault"),
        ({"faults": "corrupt:0.1"}, "list"),
        ({"baud": 0}, "baud"),
    ],
)
def test_serve_refuses_bad_options_before_serving(options: dict[str, object], says: str) -> None:
    with pytest.raises(UsageError, match=says):
        serve(SimConfig(), on_ready=lambda endpoints: pytest.fail("served"), **options)  # type: ignore[arg-type]


def test_the_module_runs_as_a_program_and_stops_on_sigterm(tmp_path: Path) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "robostar.sim", "--listen", "127.0.0.1:0", "--state", str(tmp_path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        url = proc.stdout.readline().strip()
        assert url.startswith("tcp://127.0.0.1:"), url
        sock, side = tcp_side(url)
        with sock:
            side.answer(SetSpeed(1, 123).encode())
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(WAIT) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(WAIT)
    assert (tmp_path / "state.json").is_file()


def test_the_program_reports_a_bad_option_and_exits_2() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "robostar.sim", "--fault", "explode"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert "error: fault 'explode'" in done.stderr


def test_a_fragment_left_on_the_line_would_spoil_the_next_request() -> None:
    # Why the server closes a departed client's fragment: a request whose ETX went out without
    # its LRC makes the next client's STX read as that LRC; its request is lost, answered NAK.
    peer = Canned()
    request = encode_packet(AA)
    peer.feed(request[:-1] + request, 0.0)
    assert peer.output(0.0) == bytes((NAK,))
    assert peer.requests == []
