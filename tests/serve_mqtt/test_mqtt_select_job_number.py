"""select_job over MQTT by JOB number as well as by name (issue #31): the number is looked up in
the channel's file listing and the job selected is that file; a number naming no JOB file, or a
request giving both a name and a number, is refused in words before anything is sent."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

from robostar.commands.job import ReadJobName

from .conftest import Broker, Requester, serving, until

pytestmark = pytest.mark.timeout(120)

ALLOW = ["servo", "home", "select_job"]


def test_select_job_by_number(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with (
            serving(broker, audit, allow=ALLOW) as (server, _),
            Requester.connect(broker) as req,
        ):
            line = server.lines["cell1"]
            for n, (name, params) in enumerate(
                [("servo", {"channel": 1, "on": True}), ("home", {"channel": 1})]
            ):
                await req.send(name, json.dumps({**params, "id": f"prep{n}"}).encode())
                await until(lambda n=n: req.by_id(f"prep{n}") != [], 30)

            def homed() -> bool:
                status = line.model.get("ch1/status")
                return status is not None and status.value.origin and not status.value.running

            await until(homed, 30)
            requests = [
                {"channel": 1, "number": 1},  # the simulator's DEMO.JOB
                {"channel": 1, "number": 42},  # no such JOB
                {"channel": 1, "number": 1, "file": "DEMO.JOB"},  # both: refused
                {"channel": 1, "number": "1"},  # not a number
            ]
            for n, params in enumerate(requests):
                await req.send("select_job", json.dumps({**params, "id": n}).encode())
                await until(lambda n=n: req.by_id(n) != [], 30)
            answers = [req.by_id(n)[0][1] for n in range(len(requests))]
            job = await line.read(ReadJobName(1), max_age=0)
        assert [a["ok"] for a in answers] == [True, False, False, False], answers
        assert "no JOB file numbered 42" in answers[1]["error"]
        assert "1 = DEMO.JOB" in answers[1]["error"]
        assert "not both" in answers[2]["error"]
        assert "number" in answers[3]["error"]
        assert str(job) == "DEMO.JOB"
        entries = [json.loads(line) for line in audit.read_text().splitlines()]
        selected = [e for e in entries if "SelectJob" in e["what"]]
        assert [e["outcome"] for e in selected] == ["ok"], selected
        refused = [e for e in entries if e["what"] == "cmd/select_job"]
        assert len(refused) == 3 and all(e["outcome"].startswith("refused") for e in refused)

    asyncio.run(main())
