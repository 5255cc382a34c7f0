"""Running the cell over MQTT: home, job select, step, start and stop, and
reset_alarms as allowlisted commands, each through the lease and the audit log, answered on the
result topic; a step is step mode then one start; a name not allowed stays refused."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

from robostar.commands.job import ReadJobName

from .conftest import Broker, Requester, serving, until

pytestmark = pytest.mark.timeout(120)

ALLOW = ["servo", "home", "select_job", "step_job", "start_job", "stop_job", "reset_alarms"]


def test_home_select_step_and_reset_over_mqtt(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with (
            serving(broker, audit, allow=ALLOW) as (server, _),
            Requester.connect(broker) as req,
        ):
            requests = [
                ("servo", {"channel": 1, "on": True}),
                ("home", {"channel": 1}),
                ("select_job", {"channel": 1, "file": "DEMO.JOB"}),
                ("step_job", {"channel": 1}),
                ("stop_job", {"channel": 1}),
                ("reset_alarms", {}),
                ("select_job", {"channel": 1, "file": 7}),  # refused: a name, not a number
            ]
            model = server.lines["cell1"].model

            def homed() -> bool:
                status = model.get("ch1/status")
                return status is not None and status.value.origin and not status.value.running

            for n, (name, params) in enumerate(requests):
                if name == "select_job":
                    await until(homed, 30)  # the controller selects no job before its origin
                await req.send(name, json.dumps({**params, "id": n}).encode())
                await until(lambda n=n: req.by_id(n) != [], 30)
            answers = [req.by_id(n)[0][1] for n in range(len(requests))]
            job = await server.lines["cell1"].read(ReadJobName(1), max_age=0)
        assert [a["ok"] for a in answers] == [True] * 6 + [False], answers
        assert "file" in answers[-1]["error"]
        assert str(job) == "DEMO.JOB"
        entries = [json.loads(line) for line in audit.read_text().splitlines()]
        done = [e["what"] for e in entries if e["face"] == "mqtt" and e["outcome"] == "ok"]
        for code in ("Home", "SelectJob", "SetJobMode", "StartJob", "StopJob", "ResetAlarms"):
            assert any(code in what for what in done), (code, done)

    asyncio.run(main())
