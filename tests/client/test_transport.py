"""Transports: URLs, every kind of pipe, and errors that say what is wrong and what to do."""

from __future__ import annotations

import asyncio
import errno
import os
import socket
import threading
import time
from collections.abc import Iterator

import pytest
import serial

from robostar.errors import PortError, UsageError
from robostar.sim import VirtualController
from robostar.transport import (
    AsyncPeerTransport,
    AsyncSerialTransport,
    AsyncTcpTransport,
    PeerTransport,
    SerialTransport,
    TcpTransport,
    ThreadedAsyncTransport,
    async_transport_for_url,
    open_async_transport,
    open_transport,
    tcp,
    transport_for_url,
)
from robostar.transport.serial_port import port_error
from robostar.transport.url import Kind, parse_url

pytestmark = pytest.mark.timeout(20)

AA = b"\x02\xffAA\x03\xff"  # read status, as the manual frames it
posix_only = pytest.mark.skipif(os.name != "posix", reason="needs pseudo-terminals")


# -- URLs ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("url", "kind", "target", "options"),
    [
        ("/dev/ttyUSB0", Kind.SERIAL, "/dev/ttyUSB0", {}),
        ("COM3", Kind.SERIAL, "COM3", {}),
        ("serial:///dev/ttyS1?baudrate=57600", Kind.SERIAL, "/dev/ttyS1", {"baudrate": "57600"}),
        ("serial://COM4", Kind.SERIAL, "COM4", {}),
        ("tcp://127.0.0.1:20001", Kind.TCP, "127.0.0.1", {}),
        ("tcp://localhost?connect_timeout=1", Kind.TCP, "localhost", {"connect_timeout": "1"}),
        ("loop://", Kind.PYSERIAL_URL, "loop://", {}),
        (
            "rfc2217://127.0.0.1:7000?logging=debug",
            Kind.PYSERIAL_URL,
            "rfc2217://127.0.0.1:7000?logging=debug",
            {},
        ),
        (
            "sim://?channels=1&robot=xy",
            Kind.SIM,
            "channels=1&robot=xy",
            {"channels": "1", "robot": "xy"},
        ),
    ],
)
def test_urls_are_parsed(url: str, kind: Kind, target: str, options: dict[str, str]) -> None:
    endpoint = parse_url(url)
    assert (endpoint.kind, endpoint.target, dict(endpoint.options)) == (kind, target, options)


def test_tcp_port_defaults_to_the_gateways() -> None:
    assert parse_url("tcp://192.0.2.1").port == 20000
    assert parse_url("tcp://192.0.2.1:1234").port == 1234


def test_caller_options_override_the_query() -> None:
    endpoint = parse_url("serial:///dev/x?baudrate=9600", {"baudrate": 19200})
    assert endpoint.options["baudrate"] == 19200


@pytest.mark.parametrize(
    ("url", "options", "says"),
    [
        ("", {}, "url"),
        ("ftp://host", {}, "unknown scheme"),
        ("serial://", {}, "needs a device"),
        ("tcp://:20000", {}, "needs a host"),
        ("tcp://host:99999", {}, "port"),
        ("/dev/ttyUSB0", {"baud": 9600}, "unknown option 'baud'"),
        ("/dev/ttyUSB0", {"baudrate": "fast"}, "option baudrate"),
        ("/dev/ttyUSB0", {"parity": "X"}, "option parity"),
        ("/dev/ttyUSB0", {"rtscts": "maybe"}, "option rtscts"),
        ("tcp://h:1", {"connect_timeout": -1}, "option connect_timeout"),
    ],
)
def test_bad_urls_and_options_name_the_problem(
    url: str, options: dict[str, object], says: str
) -> None:
    with pytest.raises(UsageError, match=says):
        transport_for_url(url, **options)


def test_serial_options_are_typed_from_the_query() -> None:
    transport = transport_for_url("serial:///dev/x?baudrate=57600&parity=e&stopbits=2&rtscts=on")
    assert isinstance(transport, SerialTransport)
    assert transport.settings.baudrate == 57600
    assert transport.settings.parity == "E"
    assert transport.settings.stopbits == 2.0 and transport.settings.rtscts is True
    assert not transport.is_open


def test_defaults_are_the_n1s_115200_8n1_without_flow_control() -> None:
    settings = transport_for_url("/dev/x").settings  # type: ignore[attr-defined]
    assert (settings.baudrate, settings.bytesize, settings.parity, settings.stopbits) == (
        115200,
        8,
        "N",
        1,
    )
    assert not (settings.rtscts or settings.xonxoff or settings.dsrdtr)


# -- open errors say which and what to do -----------------------------------------------------
def test_a_missing_device_says_so() -> None:
    with pytest.raises(PortError, match="no such port") as caught:
        open_transport("/dev/robostar-no-such-port")
    assert "/dev/robostar-no-such-port" in str(caught.value)
    assert caught.value.errno == errno.ENOENT


@pytest.mark.parametrize(
    ("code", "says"),
    [
        (errno.EACCES, "dialout"),
        (errno.EPERM, "dialout"),
        (errno.EBUSY, "busy"),
        (errno.EAGAIN, "busy"),
        (errno.ENOENT, "no such port"),
        (errno.EIO, "could not open"),
    ],
)
def test_open_errors_are_explained(code: int, says: str) -> None:
    error = port_error("/dev/ttyUSB0", serial.SerialException(code, "could not open port"))
    assert says in str(error) and str(error).startswith("/dev/ttyUSB0: ")
    assert isinstance(error, OSError)


@pytest.fixture
def pty_pair() -> Iterator[tuple[int, str]]:
    master, slave = os.openpty()
    path = os.ttyname(slave)
    os.close(slave)
    try:
        yield master, path
    finally:
        os.close(master)


@posix_only
def test_a_port_held_by_another_program_is_busy(pty_pair: tuple[int, str]) -> None:
    _, path = pty_pair
    with open_transport(path), pytest.raises(PortError, match="busy"):
        open_transport(path)


@posix_only
def test_serial_round_trip_over_a_pty(pty_pair: tuple[int, str]) -> None:
    master, path = pty_pair
    with open_transport(path) as transport:
        assert transport.read(0) == b""
        assert transport.read(0.05) == b""
        transport.write(AA)
        assert os.read(master, 100) == AA
        os.write(master, b"\x06\x02\x30")
        got = transport.read(1.0)
        while len(got) < 3:
            got += transport.read(1.0)
        assert got == b"\x06\x02\x30"
    assert not transport.is_open
    with pytest.raises(PortError, match="not open"):
        transport.read(0)


@posix_only
def test_a_pty_read_takes_all_that_waits_at_once(pty_pair: tuple[int, str]) -> None:
    master, path = pty_pair
    with open_transport(path) as transport:
        os.write(master, bytes(range(0x20, 0x7F)) * 8)  # 760 bytes, one write
        time.sleep(0.05)
        assert transport.read(1.0) == bytes(range(0x20, 0x7F)) * 8


@posix_only
def test_a_pty_whose_other_end_went_away_is_a_closed_line() -> None:
    master, slave = os.openpty()
    path = os.ttyname(slave)
    os.close(slave)
    transport = open_transport(path)
    os.close(master)
    with pytest.raises(PortError, match="read failed"):
        transport.read(1.0)
    assert not transport.is_open


def test_pyserial_loop_url_echoes() -> None:
    with open_transport("loop://", baudrate=9600) as transport:
        transport.write(AA)
        assert transport.read(1.0) == AA
        assert transport.read(0) == b""


# -- TCP ---------------------------------------------------------------------------------------
@pytest.fixture
def echo_server() -> Iterator[tuple[str, int, list[socket.socket]]]:
    listener = socket.create_server(("127.0.0.1", 0))
    accepted: list[socket.socket] = []

    def serve() -> None:
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            accepted.append(conn)
            threading.Thread(target=echo, args=(conn,), daemon=True).start()

    def echo(conn: socket.socket) -> None:
        while True:
            try:
                data = conn.recv(100)
            except OSError:
                return
            if not data or data == b"bye":
                conn.close()
                return
            conn.sendall(data)

    threading.Thread(target=serve, daemon=True).start()
    host, port = listener.getsockname()
    yield host, port, accepted
    listener.close()


def test_tcp_round_trip_nodelay_and_lost_connection(
    echo_server: tuple[str, int, list[socket.socket]],
) -> None:
    host, port, _ = echo_server
    transport = open_transport(f"tcp://{host}:{port}")
    assert isinstance(transport, TcpTransport)
    sock = transport._sock
    assert sock is not None and sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
    transport.write(AA)
    assert transport.read(1.0) == AA
    assert transport.read(0.02) == b""
    transport.write(b"bye")
    with pytest.raises(PortError, match="connection was lost"):
        transport.read(1.0)
    assert not transport.is_open
    transport.open()  # a closed transport can be opened again
    transport.write(AA)
    assert transport.read(1.0) == AA
    transport.close()


def test_tcp_read_longer_than_the_kernels_bound(
    echo_server: tuple[str, int, list[socket.socket]], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A read allowed more than SO_RCVTIMEO (the bound on a blocking recv) waits the rest:
    nothing arriving is an empty read, and bytes arriving after the bound are still read."""
    monkeypatch.setattr(tcp, "_RCVTIMEO", 0.01)
    host, port, accepted = echo_server
    transport = open_transport(f"tcp://{host}:{port}")
    assert transport.read(0.05) == b""
    transport.write(AA)
    assert transport.read(1.0) == AA
    later = threading.Timer(0.05, accepted[-1].sendall, args=(AA,))
    later.start()
    try:
        assert transport.read(5.0) == AA
    finally:
        later.join()
    assert transport.is_open
    transport.close()


def test_pyserial_socket_url(echo_server: tuple[str, int, list[socket.socket]]) -> None:
    host, port, _ = echo_server
    with open_transport(f"socket://{host}:{port}") as transport:
        transport.write(AA)
        got = b""
        while len(got) < len(AA):
            got += transport.read(1.0)
        assert got == AA


def test_a_refused_connection_says_so() -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    with pytest.raises(PortError, match="connection refused"):
        open_transport(f"tcp://127.0.0.1:{port}")


# -- in-process ----------------------------------------------------------------------------------
def test_sim_url_builds_the_simulator_from_its_query() -> None:
    transport = transport_for_url("sim://?channels=1&robot=xy&axes=3", speedup="10")
    assert isinstance(transport, PeerTransport)
    controller = transport.peer
    assert isinstance(controller, VirtualController)
    assert len(controller.config.channels) == 1 and controller.config.speedup == 10
    with transport:
        transport.write(AA)
        answer = transport.read(1.0)
    assert answer.startswith(b"\x02\x30")


def test_peer_transport_waits_for_the_peer_but_not_past_its_timeout() -> None:
    class Silent:
        def feed(self, data: bytes, now: float) -> None:
            pass

        def output(self, now: float) -> bytes:
            return b""

        def next_deadline(self) -> float | None:
            return 0.0  # always overdue: must not make the reader spin or return early

    with PeerTransport(Silent()) as transport:
        assert transport.read(0.05) == b""


# -- asyncio -------------------------------------------------------------------------------------
def test_async_transports_by_url() -> None:
    assert isinstance(async_transport_for_url("tcp://127.0.0.1:1"), AsyncTcpTransport)
    assert isinstance(async_transport_for_url("/dev/ttyUSB0"), AsyncSerialTransport)
    assert isinstance(async_transport_for_url("socket://127.0.0.1:1"), AsyncSerialTransport)
    assert isinstance(async_transport_for_url("loop://"), ThreadedAsyncTransport)
    assert isinstance(async_transport_for_url("sim://"), AsyncPeerTransport)


def test_async_tcp_round_trip(echo_server: tuple[str, int, list[socket.socket]]) -> None:
    host, port, _ = echo_server

    async def main() -> None:
        transport = await open_async_transport(f"tcp://{host}:{port}")
        async with transport:
            await transport.write(AA)
            assert await transport.read(1.0) == AA
            assert await transport.read(0) == b""
            await transport.write(b"bye")
            with pytest.raises(PortError, match="lost"):
                await transport.read(1.0)

    asyncio.run(main())


def test_async_tcp_nowait_twins_do_what_write_and_read_0_do(
    echo_server: tuple[str, int, list[socket.socket]],
) -> None:
    """write_nowait writes at once (nothing to await) or hands back what write() would do;
    read_nowait is read(0) when it needs no awaiting, else None (then read(0) says why)."""
    host, port, _ = echo_server

    async def main() -> None:
        transport = await open_async_transport(f"tcp://{host}:{port}")
        assert isinstance(transport, AsyncTcpTransport)
        assert transport.read_nowait() == b""
        assert transport.write_nowait(AA) is None
        assert await transport.read(1.0) == AA
        assert transport.write_nowait(AA) is None
        await asyncio.sleep(0.05)
        assert transport.read_nowait() == AA  # bytes already here
        assert transport.read_nowait() == b""
        # A full write buffer: written, and the awaitable waits for it to drain.
        protocol = transport._protocol
        assert protocol is not None
        protocol.pause_writing()
        pending = transport.write_nowait(AA)
        assert pending is not None
        asyncio.get_running_loop().call_later(0.01, protocol.resume_writing)
        await pending
        assert await transport.read(1.0) == AA
        # A lost line: nothing written; what is handed back raises as write() does.
        transport.write_nowait(b"bye")
        await asyncio.sleep(0.05)
        assert transport.read_nowait() is None
        with pytest.raises(PortError, match="lost"):
            await transport.read(1.0)
        pending = transport.write_nowait(AA)
        assert pending is not None
        with pytest.raises(PortError, match="not open"):
            await pending
        assert transport.read_nowait() is None

    asyncio.run(main())


def test_async_nowait_twins_leave_a_subclass_its_own_write_and_read(
    echo_server: tuple[str, int, list[socket.socket]],
) -> None:
    host, port, _ = echo_server
    calls: list[str] = []

    class Counting(AsyncTcpTransport):
        async def write(self, data: bytes) -> None:
            calls.append("write")
            await super().write(data)

        async def read(self, timeout: float) -> bytes:
            calls.append("read")
            return await super().read(timeout)

    async def main() -> None:
        transport = Counting(host, port)
        await transport.open()
        assert transport.read_nowait() is None
        pending = transport.write_nowait(AA)
        assert pending is not None
        await pending
        assert await transport.read(1.0) == AA
        await transport.close()

    asyncio.run(main())
    assert calls == ["write", "read"]
    assert AsyncPeerTransport(CannedPeerForNowait()).read_nowait() is None


def test_async_read_answering_writes_the_reply_where_the_bytes_land(
    echo_server: tuple[str, int, list[socket.socket]],
) -> None:
    """read_answering offers arriving bytes to the answerer in the transport's own callback
    (no task is running there): what it takes is answered at once and the read returns b"";
    what it declines is the read's, nothing written."""
    host, port, _ = echo_server
    offered: list[tuple[bytes, float, object]] = []

    def answer(data: bytes, now: float) -> bytes | None:
        offered.append((data, now, asyncio.current_task()))
        return b"ACK!" if data == AA else None

    async def main() -> None:
        transport = await open_async_transport(f"tcp://{host}:{port}")
        async with transport:
            before = time.monotonic()
            await transport.write(AA)
            assert await transport.read_answering(1.0, answer) == b""
            [(data, now, task)] = offered
            assert data == AA and task is None and before <= now <= time.monotonic()
            assert await transport.read(1.0) == b"ACK!"  # written back by the callback, echoed
            await transport.write(b"other")
            assert await transport.read_answering(1.0, answer) == b"other"  # declined
            assert await transport.read(0.05) == b""  # and nothing written for it
            # Bytes already waiting are the read's: nothing is offered.
            await transport.write(AA)
            await asyncio.sleep(0.05)
            assert await transport.read_answering(1.0, answer) == AA
            assert len(offered) == 2

    asyncio.run(main())


def test_async_bytes_behind_a_taken_answer_stay_for_the_next_read(
    echo_server: tuple[str, int, list[socket.socket]],
) -> None:
    """A loop that reads a socket twice in one turn (libuv) can deliver bytes behind the
    answer before the task resumes: the answered read returns b"" and leaves them for the
    next read (the drain), not to be dropped with the finished exchange."""
    host, port, _ = echo_server

    async def main() -> None:
        transport = await open_async_transport(f"tcp://{host}:{port}")
        assert isinstance(transport, AsyncTcpTransport)
        protocol = transport._protocol
        assert protocol is not None
        received = protocol.data_received

        def twice_a_turn(data: bytes) -> None:
            had = protocol.answer
            received(data)
            if had is not None and protocol.answer is None:
                received(b"behind")  # the next read of the same turn

        protocol.data_received = twice_a_turn  # type: ignore[method-assign]
        async with transport:
            await transport.write(AA)
            assert await transport.read_answering(1.0, lambda data, now: b"") == b""
            assert transport.read_nowait() == b"behind"

    asyncio.run(main())


def test_async_read_answering_reports_a_reply_that_could_not_be_written(
    echo_server: tuple[str, int, list[socket.socket]],
) -> None:
    host, port, _ = echo_server

    class Broken:
        def write(self, data: bytes) -> None:
            raise OSError(errno.EPIPE, "broken pipe")

    async def main() -> None:
        transport = await open_async_transport(f"tcp://{host}:{port}")
        assert isinstance(transport, AsyncTcpTransport)
        protocol = transport._protocol
        assert protocol is not None
        line = protocol._line
        await transport.write(AA)
        protocol._line = Broken()  # type: ignore[assignment]
        try:
            with pytest.raises(PortError, match="lost"):
                await transport.read_answering(1.0, lambda data, now: b"\x06")
        finally:
            if line is not None:
                line.close()

    asyncio.run(main())


def test_async_read_answering_is_read_where_nothing_can_be_offered(
    echo_server: tuple[str, int, list[socket.socket]],
) -> None:
    """A transport without the callback (the base's default) or a subclass with its own read()
    reads as read() does; the answerer is never called."""
    host, port, _ = echo_server
    calls: list[str] = []

    class Counting(AsyncTcpTransport):
        async def read(self, timeout: float) -> bytes:
            calls.append("read")
            return await super().read(timeout)

    def never(data: bytes, now: float) -> bytes | None:
        raise AssertionError("offered")

    async def main() -> None:
        transport = Counting(host, port)
        await transport.open()
        await transport.write(AA)
        assert await transport.read_answering(1.0, never) == AA
        await transport.close()
        peer = AsyncPeerTransport(CannedPeerForNowait())
        await peer.open()
        assert await peer.read_answering(0.0, never) == b""
        await peer.close()

    asyncio.run(main())
    assert calls == ["read"]


class CannedPeerForNowait:
    def feed(self, data: bytes, now: float) -> None:
        pass

    def output(self, now: float) -> bytes:
        return b""

    def next_deadline(self) -> float | None:
        return None


@posix_only
def test_async_serial_round_trip_over_a_pty(pty_pair: tuple[int, str]) -> None:
    master, path = pty_pair

    async def main() -> None:
        async with async_transport_for_url(path) as transport:
            await transport.write(AA)
            await asyncio.sleep(0.05)
            assert os.read(master, 100) == AA
            os.write(master, b"\x06")
            assert await transport.read(1.0) == b"\x06"
            assert await transport.read(0.02) == b""

    asyncio.run(main())


def test_async_missing_port_and_loop_url() -> None:
    async def main() -> None:
        with pytest.raises(PortError, match="no such port"):
            await open_async_transport("/dev/robostar-no-such-port")
        async with async_transport_for_url("loop://") as loop:
            await loop.write(AA)
            assert await loop.read(1.0) == AA

    asyncio.run(main())
