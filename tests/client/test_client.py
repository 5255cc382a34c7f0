"""The clients' own behaviour: settings, life cycle, the wire trace, probing, the public names."""

from __future__ import annotations

import asyncio
import json
import os
from pathlib import Path

import pytest

from robostar import AsyncClient, Client, probe
from robostar.client import TraceRecord
from robostar.errors import PortError, UsageError
from robostar.sim import VirtualController
from robostar.sim.listeners import PtyServer
from robostar.transport import PeerTransport

from .conftest import sim_config

pytestmark = pytest.mark.timeout(30)


@pytest.fixture
def controller() -> VirtualController:
    return VirtualController(sim_config())


# -- settings and life cycle -------------------------------------------------------------------
@pytest.mark.parametrize(
    ("options", "says"),
    [
        ({"timeout": 0}, "timeout"),
        ({"timeout": "2"}, "timeout"),
        ({"retries": -1}, "retries"),
        ({"retries": 1.5}, "retries"),
        ({"poll_interval": 0}, "poll_interval"),
        ({"keepalive": 0.5}, "keepalive"),
        ({"reconnect": 1}, "reconnect"),
        ({"trace": 42}, "trace"),
    ],
)
def test_bad_settings_are_refused(options: dict[str, object], says: str) -> None:
    with pytest.raises(UsageError, match=says):
        Client("sim://", **options)  # type: ignore[arg-type]
    with pytest.raises(UsageError, match=says):
        AsyncClient("sim://", **options)  # type: ignore[arg-type]


def test_transport_options_go_with_a_url_only(controller: VirtualController) -> None:
    with pytest.raises(UsageError, match="transport options"):
        Client(PeerTransport(controller), baudrate=9600)


def test_a_sim_url_gives_a_working_client() -> None:
    with Client("sim://?channels=1&speedup=50") as client:
        assert client.info().max_channels == 1
        assert client.url == "sim://?channels=1&speedup=50"


def test_a_closed_client_refuses_calls(controller: VirtualController) -> None:
    client = Client(PeerTransport(controller))
    client.close()
    client.close()
    with pytest.raises(PortError, match="closed"):
        client.status()


def test_a_missing_port_fails_at_construction() -> None:
    with pytest.raises(PortError, match="no such port"):
        Client("/dev/robostar-no-such-port")


def test_calling_the_client_from_its_own_callback_is_refused(
    controller: VirtualController,
) -> None:
    with Client(PeerTransport(controller)) as client:

        def progress(done: int, total: int | None) -> None:
            client.status()

        with pytest.raises(UsageError, match="inside one of its own exchanges"):
            client.download_job(1, "DEMO.JOB", progress=progress)
        assert client.status()[0].ready  # the aborted exchange left the line usable


def test_async_client_connects_on_first_use(controller: VirtualController) -> None:
    from robostar.transport import AsyncPeerTransport

    async def main() -> None:
        client = AsyncClient(AsyncPeerTransport(controller))
        assert not client.transport.is_open
        assert (await client.status())[0].ready
        await client.close()
        with pytest.raises(PortError, match="closed"):
            await client.status()

    asyncio.run(main())


def test_concurrent_threads_share_one_client(controller: VirtualController) -> None:
    import threading

    errors: list[BaseException] = []
    with Client(PeerTransport(controller)) as client:

        def work(index: int) -> None:
            try:
                for value in range(20):
                    client.write_global_int(index, value)
                    assert client.read_global_int(index) == value
            except BaseException as exc:
                errors.append(exc)

        threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    assert errors == []
    assert controller.executions["GW"] == 80


# -- the wire trace ----------------------------------------------------------------------------
def test_trace_to_a_callable_decodes_every_frame(controller: VirtualController) -> None:
    records: list[TraceRecord] = []
    with Client(PeerTransport(controller), trace=records.append) as client:
        client.set_speed(1, 250)
        client.speed(1)
    kinds = [(r.direction, r.kind, r.command) for r in records]
    assert kinds == [
        ("tx", "request", "CB"),
        ("rx", "answer", "CB"),
        ("tx", "ACK", None),
        ("tx", "request", "CA"),
        ("rx", "answer", "CA"),
        ("tx", "ACK", None),
    ]
    request = records[0]
    assert request.fields == {"channel": 1, "speed": 250}
    assert request.hex.startswith("02 ff 43 42")
    assert records[4].flag == "0x30" and records[4].fields == {"body": "0250"}


def test_trace_to_a_file_is_json_lines(controller: VirtualController, tmp_path: Path) -> None:
    path = tmp_path / "wire.jsonl"
    with Client(PeerTransport(controller), trace=path) as client:
        client.position(1, "angle")
        client.upload_job(1, "T.JOB", ["MAIN", "EOP"], number=5)
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert {"time", "direction", "hex", "kind"} <= set(lines[0])
    assert lines[0]["command"] == "AC" and lines[0]["fields"] == {"channel": 1, "kind": "ANGLE"}
    uploads = [line for line in lines if line["kind"] == "upload line"]
    assert [u["fields"]["line"] for u in uploads] == ["MAIN", "EOP"]
    assert any(line["kind"] == "upload end" for line in lines)
    assert all(isinstance(line["time"], float) for line in lines)


def test_trace_marks_corrupt_frames(controller: VirtualController) -> None:
    from robostar.sim.faults import FaultInjector

    records: list[TraceRecord] = []
    faults = FaultInjector(controller, seed=5)
    with Client(PeerTransport(faults), trace=records.append) as client:
        faults.schedule("corrupt-lrc", "to_host")
        client.status()
    assert [r.kind for r in records if r.direction == "rx"][:2] == ["corrupt", "answer"]
    assert ("tx", "NAK") in [(r.direction, r.kind) for r in records]


# -- probe -------------------------------------------------------------------------------------
def test_probe_a_sim_url() -> None:
    result = probe("sim://?speedup=50")
    assert result.found and result.baudrate is None and result.status is not None
    assert "answered" in str(result)


@pytest.mark.skipif(os.name != "posix", reason="needs a pseudo-terminal")
def test_probe_finds_the_first_rate_that_answers(controller: VirtualController) -> None:
    with PtyServer(controller) as server:
        result = probe(server.device_path, timeout=0.3)
    assert result.found and result.baudrate == 115200
    assert [a.baudrate for a in result.attempts] == [115200]


def test_probe_tries_every_rate_and_reports_none() -> None:
    # loop:// echoes the request back: never an answer, at any rate.
    result = probe("loop://", timeout=0.05)
    assert not result.found and result.baudrate is None
    assert [a.baudrate for a in result.attempts] == [115200, 57600, 38400, 19200, 9600, 230400]
    assert all(a.error for a in result.attempts)
    assert "no answer" in str(result)


def test_probe_raises_for_a_port_that_cannot_open() -> None:
    with pytest.raises(PortError, match="no such port"):
        probe("/dev/robostar-no-such-port")


# -- public names ------------------------------------------------------------------------------
def test_the_package_exports_the_client_the_types_and_the_errors() -> None:
    import robostar.errors
    import robostar.types

    names = set(robostar.__all__)
    assert {"Client", "AsyncClient", "probe"} <= names
    assert set(robostar.types.__all__) <= names
    assert {n for n in robostar.errors.__all__ if n != "error_for_flag"} <= names
    for name in robostar.__all__:
        assert getattr(robostar, name) is not None
