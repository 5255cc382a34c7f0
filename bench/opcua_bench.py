"""The OPC UA face's figures (printed, never asserted): ``python -m bench.opcua_bench``.

1. Latency to a subscriber (asyncua's client, SignAndEncrypt, publishing interval asked 0):
   a. a change of a line's model -> the data change notification (the face's own share);
   b. a position the poller read from the moving simulator -> the notification (the value's
      source timestamp to its arrival: the face plus the subscription);
   c. a speed change acknowledged by the simulator -> SpeedOverride's notification (the
      poll the write triggers, the face and the subscription).
2. Alarms as conditions: an alarm in the line's model -> the subscriber's event; an
   Acknowledge call's round trip, and the call -> the acknowledgement's event.
3. Reads: a Read of SpeedOverride accepting any age (maxAge one hour: the model's sample) and
   one asking maxAge 0 (a CB read on the line, through its queue).
4. Startup, each in a fresh process: cold (no certificate, no nodeset cache: the key is made
   and the nodesets imported) and cached (both kept from the cold run).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import subprocess
import sys
import tempfile
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from asyncua import Client, ua
from tests.serve_opcua.conftest import (
    PASSWORDS,
    Model,
    Setup,
    connect,
    make_setup,
    read_values,
    serving,
)

from bench.measure import percentile
from robostar.commands.control import SetSpeed
from robostar.commands.motion import Home, Move
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.lease import Who
from robostar.serve.users import Role, UserStore
from robostar.types import Alarm, CoordSystem, MotionType

BENCH = Who("bench", "cli")


class _Arrivals:
    def __init__(self) -> None:
        self.got: list[tuple[float, float, Any]] = []
        """(perf_counter, time.time, DataValue) of each notification."""

    def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
        self.got.append((time.perf_counter(), time.time(), data.monitored_item.Value))

    async def next_after(self, count: int) -> float:
        """Wait for notification number ``count + 1``; its perf_counter time."""
        while len(self.got) == count:
            await asyncio.sleep(0.0005)
        return self.got[-1][0]


@contextlib.asynccontextmanager
async def _watching(client: Client, node: Any) -> AsyncIterator[_Arrivals]:
    """Every data change of ``node`` (publishing and sampling interval asked 0)."""
    arrivals = _Arrivals()
    subscription = await client.create_subscription(0, arrivals)
    await subscription.subscribe_data_change(node, sampling_interval=0)
    try:
        yield arrivals
    finally:
        await subscription.delete()


async def _speed_override(client: Client) -> Any:
    return await Model(client).path(
        "rob:MotionDevices", "ven:Channel1", "di:ParameterSet", "rob:SpeedOverride"
    )


def _report(label: str, delays: list[float]) -> None:
    p50, p99 = percentile(delays, 50) * 1e3, percentile(delays, 99) * 1e3
    print(f"  {label:<44} p50 {p50:6.2f} ms   p99 {p99:6.2f} ms ({len(delays)})")


async def model_to_subscriber(setup: Setup, n: int = 300) -> None:
    # the poller reads the speed only every 100 s: the bench's values are not overwritten
    async with (
        serving(setup, url="sim://", poll=100.0, slow=100.0) as server,
        connect(server, setup) as client,
        _watching(client, await _speed_override(client)) as arrivals,
    ):
        await asyncio.sleep(0.5)
        model = server.line("cell1").model
        delays = []
        for k in range(1, n + 1):
            count = len(arrivals.got)
            sent = time.perf_counter()
            model.set("ch1/speed", 10 * k)
            delays.append(await arrivals.next_after(count) - sent)
    _report("model change -> notification", delays)


async def moving_to_subscriber(setup: Setup, seconds: float = 10.0) -> None:
    async with serving(setup, url="sim://", poll=0.05) as server:
        line = server.line("cell1")
        await line.execute(Home(1), who=BENCH, implicit_lease=True)
        while not (s := line.model.get("ch1/status")) or not s.value.origin or s.value.running:
            await asyncio.sleep(0.05)
        async with connect(server, setup) as client:
            model = Model(client)
            async with _watching(client, await model.axis_position(1, 1)) as arrivals:
                end = time.monotonic() + seconds
                targets = ((100.0, 60.0, 0.0, 0.0), (-100.0, -60.0, 0.0, 0.0))
                k = 0
                while time.monotonic() < end:
                    move = Move(1, MotionType.JOINT, CoordSystem.ANGLE, (targets[k % 2],))
                    await line.execute(move, who=BENCH, implicit_lease=True)
                    k += 1
                    await asyncio.sleep(0.2)
                    while (s := line.model.get("ch1/status")) and s.value.running:
                        await asyncio.sleep(0.02)
            delays = [
                wall - value.SourceTimestamp.timestamp()
                for _, wall, value in arrivals.got[1:]
                if value.SourceTimestamp is not None
            ]
            speeds = []
            async with _watching(client, await _speed_override(client)) as arrivals:
                await asyncio.sleep(0.3)
                for k in range(40):
                    count = len(arrivals.got)
                    await line.execute(SetSpeed(1, 100 + 10 * k), who=BENCH, implicit_lease=True)
                    done = time.perf_counter()
                    speeds.append(await arrivals.next_after(count) - done)
    _report("polled position (source time) -> notification", delays)
    _report("speed write acknowledged -> notification", speeds)


class _Events:
    def __init__(self) -> None:
        self.got: list[tuple[float, Any]] = []

    def event_notification(self, event: Any) -> None:
        self.got.append((time.perf_counter(), event))

    async def next_after(self, count: int) -> tuple[float, Any]:
        while len(self.got) <= count:
            await asyncio.sleep(0.0005)
        return self.got[count]


async def alarms_as_conditions(setup: Setup, n: int = 100) -> None:
    """Alarm -> event, and Acknowledge's round trip, on the line's model (no poll involved)."""
    acknowledge = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
    async with (
        serving(setup, url="sim://", poll=100.0, slow=100.0) as server,
        connect(server, setup) as client,
    ):
        model = Model(client)
        events = _Events()
        subscription = await client.create_subscription(0, events)
        await subscription.subscribe_alarms_and_conditions(
            await model.system(), await model.alarm_event_type()
        )
        await asyncio.sleep(0.3)
        line_model = server.line("cell1").model
        raised, calls, acked = [], [], []
        for k in range(n):
            code = 2000 + k
            count = len(events.got)
            sent = time.perf_counter()
            line_model.set("alarms", (Alarm(code, "bench"),))
            arrived, event = await events.next_after(count)
            while getattr(event, "AlarmCode", None) != code:  # the last one's clearing first
                count += 1
                arrived, event = await events.next_after(count)
            raised.append(arrived - sent)
            count = len(events.got)
            condition = client.get_node(event.NodeId)
            began = time.perf_counter()
            await condition.call_method(
                acknowledge,
                ua.Variant(event.EventId, ua.VariantType.ByteString),
                ua.Variant(ua.LocalizedText("bench"), ua.VariantType.LocalizedText),
            )
            calls.append(time.perf_counter() - began)
            arrived, _ = await events.next_after(count)
            acked.append(arrived - began)
        await subscription.delete()
    _report("alarm in the model -> condition event", raised)
    _report("Acknowledge call round trip", calls)
    _report("Acknowledge call -> acknowledged event", acked)


async def reads_by_max_age(setup: Setup, n: int = 200) -> None:
    """A Read accepting the model's sample against one asking the line (maxAge 0)."""
    async with (
        serving(setup, url="sim://", poll=0.2) as server,
        connect(server, setup) as client,
    ):
        speed = await _speed_override(client)
        face: Any = server.faces["opcua"]
        await read_values(client, [speed], 0)
        for label, max_age in (
            ("Read, maxAge 1 h (the model)", 3_600_000.0),
            ("Read, maxAge 0 (the line)", 0.0),
        ):
            times = []
            before = face.reads.line_reads
            for _ in range(n):
                began = time.perf_counter()
                await read_values(client, [speed], max_age)
                times.append(time.perf_counter() - began)
            _report(f"{label}, {face.reads.line_reads - before} line reads", times)


def startup(root: Path, runs: int = 3) -> None:
    """Each start in a process of its own: imports, address space, certificate, nodes."""
    for label, fresh in (("cold (new key, nodesets imported)", True), ("cached", False)):
        faces, totals, loads, walls = [], [], [], []
        for _ in range(runs):
            state = root / "startup"
            if fresh:
                subprocess.run(["rm", "-rf", str(state)], check=True)
            began = time.perf_counter()
            out = subprocess.run(
                [sys.executable, "-m", "bench.opcua_bench", "--startup-child", str(state)],
                check=True,
                capture_output=True,
                text=True,
            ).stdout
            walls.append(time.perf_counter() - began)
            figures = json.loads(out.strip().splitlines()[-1])
            faces.append(figures["face"])
            totals.append(figures["total"])
            loads.append(figures["load"])
        print(
            f"  startup {label:<36} face {min(faces):5.2f} s (address space"
            f" {min(loads):4.2f} s), serve() to ready {min(totals):5.2f} s, whole process"
            f" {min(walls):5.2f} s (best of {runs})"
        )


def _startup_child(state: Path) -> None:
    began = time.perf_counter()
    state.mkdir(parents=True, exist_ok=True)
    users = UserStore(state / "users.toml")
    if users.get("olga") is None:
        users.add("olga", Role.OPERATOR, PASSWORDS["olga"])
    options = {
        "listen": "127.0.0.1:0",
        "users": str(state / "users.toml"),
        "state_dir": str(state / "pki"),
        "cache_dir": str(state / "cache"),
    }
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=1.0),), faces={"opcua": options}
    )

    async def run() -> dict[str, Any]:
        async with LineServer(config) as server:
            face: Any = server.faces["opcua"]
            return {
                "face": face.startup_seconds,
                "load": face.load.seconds,
                "cached": face.load.cached,
                "total": time.perf_counter() - began,
            }

    print(json.dumps(asyncio.run(run())))


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--startup-child", type=Path)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    if args.startup_child is not None:
        _startup_child(args.startup_child)
        return 0
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        setup = make_setup(root)
        print("OPC UA face (asyncua client, Basic256Sha256 SignAndEncrypt, 2 shared cores):")
        asyncio.run(model_to_subscriber(setup, n=100 if args.quick else 300))
        asyncio.run(moving_to_subscriber(setup, seconds=4.0 if args.quick else 10.0))
        asyncio.run(alarms_as_conditions(setup, n=30 if args.quick else 100))
        asyncio.run(reads_by_max_age(setup, n=50 if args.quick else 200))
        startup(root, runs=1 if args.quick else 3)
    return 0


if __name__ == "__main__":
    sys.exit(main())
