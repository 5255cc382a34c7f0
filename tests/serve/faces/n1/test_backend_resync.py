"""An N1 host whose reply timeout differs from the server's always gets back in step with its
session: the session follows the host's RSTs and new requests, whatever the line is doing (a
controller that hangs for longer than the host waits, a host that gives an exchange up in the
same read as its request)."""

from __future__ import annotations

import asyncio
import threading
import time
from pathlib import Path

from tests.serve.line_fakes import FaultySim, n1_server

import robostar
from robostar.commands.status import ReadStatus
from robostar.errors import RobostarError
from robostar.protocol.frame import ACK, RST, FrameDecoder, Packet, encode_packet
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.sim.controller import VirtualController
from robostar.sim.listeners import SimServer

_AA = encode_packet(ReadStatus().encode())


def test_a_request_given_up_in_the_same_read_lets_the_next_one_be_answered(
    tmp_path: Path,
) -> None:
    # request, RST, request, RST, request, all in one read: the host gave two exchanges up
    # before the server could look at them; its last request is still answered
    async def main() -> bytes:
        async with n1_server(FaultySim(), tmp_path / "audit.jsonl") as (_, host, port):
            reader, writer = await asyncio.open_connection(host, port)
            rst = bytes((RST,))
            writer.write(_AA + rst + _AA + rst + _AA)
            await writer.drain()
            decoder = FrameDecoder()
            async with asyncio.timeout(5):
                while True:
                    events = decoder.feed(await reader.read(256))
                    packets = [e for e in events if isinstance(e, Packet)]
                    if packets:
                        writer.write(bytes((ACK,)))
                        await writer.drain()
                        writer.close()
                        return packets[0].data

    answer = asyncio.run(main())
    assert ReadStatus().decode_answer([answer])[0].ready


def test_a_host_with_a_shorter_timeout_reads_again_once_a_hung_controller_resumes() -> None:
    sim = SimServer(VirtualController()).start()
    config = ServeConfig(
        lines=(LineConfig("cell1", sim.url, timeout=2.0, poll_interval=0.2),),
        faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
        audit=False,
    )
    ready = threading.Event()
    stop: list[asyncio.Event] = []
    where: list[str] = []
    loop_box: list[asyncio.AbstractEventLoop] = []

    async def serve() -> None:
        async with LineServer(config) as server:
            host, port = server.faces["n1"].addresses["cell1"]  # type: ignore[attr-defined]
            where.append(f"tcp://{host}:{port}")
            loop_box.append(asyncio.get_running_loop())
            stop.append(asyncio.Event())
            ready.set()
            await stop[0].wait()

    thread = threading.Thread(target=asyncio.run, args=(serve(),), daemon=True)
    thread.start()
    assert ready.wait(10)
    outcomes: list[str] = []
    try:
        with robostar.Client(where[0], timeout=1.0, reconnect=True) as client:
            client.status()
            with sim.lock:  # the controller hangs: 3 s without a byte
                time.sleep(3.0)
            resumed = time.monotonic()
            # The first read after the resume may still meet the line's last retry; from
            # then on every read is answered.
            while time.monotonic() - resumed < 8.0 and outcomes[-5:] != ["ok"] * 5:
                try:
                    client.status()
                    outcomes.append("ok")
                except RobostarError as exc:
                    outcomes.append(type(exc).__name__)
    finally:
        loop_box[0].call_soon_threadsafe(stop[0].set)
        thread.join(10)
        sim.close()
    assert outcomes[-5:] == ["ok"] * 5, outcomes
