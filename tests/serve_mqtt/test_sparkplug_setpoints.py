"""Sparkplug setpoints as writable metrics: a DCMD writing ``ch1/speed`` (Int64) or an output's
``io/out/P/C`` (Boolean) runs the speed or output command, only when that command is allowed,
through the lease (another holder keeps it out) and the audit log, its answer the DDATA of
``cmd/<name>/result``; a value of the wrong kind and a read-only metric are refused and
audited."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from robostar.serve import LineServer, ServeConfig
from robostar.serve.lease import Who

from . import sparkplug_wire as wire
from .conftest import Broker, until
from .test_mqtt_sparkplug import GROUP, NODE, _by_name, _config, _host

pytestmark = pytest.mark.timeout(120)


def test_setpoint_writes_run_through_allowlist_lease_and_audit(
    broker: Broker, tmp_path: Path
) -> None:
    audit = tmp_path / "audit.jsonl"
    config = _config(broker, commands={"enabled": True, "allow": ["speed", "output"]})
    config = ServeConfig(lines=config.lines, faces=config.faces, audit_path=str(audit))

    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(config) as server:
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            line = server.lines["cell1"]
            birth = _by_name(host.of("DBIRTH", "cell1")[-1])
            assert host.client is not None
            topic = f"spBv1.0/{GROUP}/DCMD/{NODE}/cell1"
            results = birth["cmd/speed/result"].alias

            def speed_results() -> list[Any]:
                return [
                    json.loads(m.value)
                    for p in host.of("DDATA", "cell1")
                    for m in p.metrics
                    if m.alias == results
                ]

            def model(key: str) -> Any:
                sample = line.model.get(key)
                return None if sample is None else sample.value

            await host.client.publish(topic, wire.write_request("ch1/speed", 250), qos=1)
            await until(lambda: model("ch1/speed") == 250, 30)
            await host.client.publish(topic, wire.write_request("io/out/0/3", True), qos=1)
            await until(lambda: (out := model("io/out/0")) is not None and out.contacts[3], 30)
            await host.client.publish(topic, wire.write_request("ch1/speed", "fast"), qos=1)
            await host.client.publish(topic, wire.write_request("ch1/position/x", 5), qos=1)
            line.take_control(Who("ann", "api"), 60)
            await host.client.publish(topic, wire.write_request("ch1/speed", 900), qos=1)
            await until(lambda: len(speed_results()) >= 2, 30)
            line.release_control(Who("ann", "api"))
            speed = model("ch1/speed")
        task.cancel()
        assert speed == 250  # the write while ann held control did not run
        first, held = speed_results()[:2]
        assert first["ok"] is True
        assert held["ok"] is False and held["kind"] == "LeaseHeldError" and "ann" in held["error"]
        entries = [json.loads(line) for line in audit.read_text().splitlines()]
        ok = [e["what"] for e in entries if e["outcome"] == "ok" and e["face"] == "mqtt"]
        assert any("SetSpeed" in what for what in ok) and any("SetOutput" in w for w in ok)
        refused = {e["what"]: e["outcome"] for e in entries if e["outcome"].startswith("refused")}
        assert "whole number" in refused["DCMD ch1/speed"]
        assert "writable setpoint" in refused["DCMD ch1/position/x"]

    asyncio.run(main())


def test_setpoint_write_needs_its_command_allowed(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"
    config = _config(broker, commands={"enabled": True, "allow": ["servo"]})
    config = ServeConfig(lines=config.lines, faces=config.faces, audit_path=str(audit))

    async def main() -> None:
        host, task = await _host(broker)
        async with LineServer(config) as server:
            await until(lambda: host.of("DBIRTH", "cell1") != [])
            before = server.lines["cell1"].model.get("ch1/speed")
            assert host.client is not None and before is not None
            topic = f"spBv1.0/{GROUP}/DCMD/{NODE}/cell1"
            await host.client.publish(topic, wire.write_request("ch1/speed", before.value // 2))
            await until(lambda: "cmd/speed" in audit.read_text(), 30)
            after = server.lines["cell1"].model.get("ch1/speed")
        task.cancel()
        assert after is not None and after.value == before.value
        entries = [json.loads(line) for line in audit.read_text().splitlines()]
        assert any(e["what"] == "cmd/speed" and "not enabled" in e["outcome"] for e in entries)

    asyncio.run(main())
