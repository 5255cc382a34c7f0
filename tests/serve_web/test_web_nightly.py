"""The nightly program check: its time of day (the next one, tomorrow's once today's has
passed), a bad setting refused in words, and a run over every line recorded in the audit log
with the files changed at the pendant named."""

from __future__ import annotations

import datetime
import json

import pytest
from web_harness import Stack

from robostar.errors import UsageError
from robostar.protocol.fields import FileName
from robostar.serve.faces.web.nightly import check_all, parse_time, seconds_until
from robostar.sim.filesystem import StoredJob


def test_the_next_check_is_today_or_tomorrow() -> None:
    at = parse_time("02:30")
    assert seconds_until(at, datetime.datetime(2026, 1, 1, 2, 0)) == 30 * 60
    assert seconds_until(at, datetime.datetime(2026, 1, 1, 2, 30)) == 24 * 3600
    assert seconds_until(at, datetime.datetime(2026, 1, 1, 23, 30)) == 3 * 3600
    for bad in ("2.30", "25:00", "noon"):
        with pytest.raises(UsageError, match="HH:MM"):
            parse_time(bad)


def test_a_nightly_run_names_what_changed_at_the_pendant(stack: Stack) -> None:
    store = stack.face.app.state.deps.store
    stack.call(check_all(stack.server, store), timeout=60)  # every file kept as it is now
    changed = StoredJob(FileName.parse("NITE.JOB"), 77, ["MAIN", "DELAY 1", "EOP"])
    stack.in_sim(lambda c: c.model.channels[0].files.put(changed))
    stack.call(check_all(stack.server, store), timeout=60)
    entries = [json.loads(t) for t in stack.audit_path.read_text().splitlines()]
    nightly = [e for e in entries if e["who"] == "nightly program check"]
    assert nightly[-1]["outcome"].startswith("flagged: NITE.JOB (channel 1) new")
