"""A jog from the dashboard is one audit entry (which axis, when it started, how long, how far,
why it stopped), not the line's JogStart and JogStop beside it; a jog start the line refuses is
still in the log, in the line's own entry."""

from __future__ import annotations

import json
from typing import Any

from web_harness import Stack, ask, wait_until

from robostar.serve.lease import Who


def olga_entries(stack: Stack) -> list[dict[str, Any]]:
    entries = [json.loads(text) for text in stack.audit_path.read_text().splitlines()]
    return [e for e in entries if e["who"] == "olga" and e["face"] == "web"]


def summarized(stack: Stack) -> list[dict[str, Any]]:
    """Olga's entries once the jog's summary is written (just after the page is told)."""
    wait_until(
        lambda: any(e["what"].startswith("jog channel") for e in olga_entries(stack)),
        what="the jog's summary in the audit log",
    )
    return olga_entries(stack)


def test_a_jog_is_one_entry(stack: Stack, jog: Any) -> None:
    stack.in_sim(lambda c: setattr(c.model.channels[0], "servo", True))
    try:
        answer = ask(jog, {"type": "start", "channel": 1, "axis": 4, "direction": "+"})
        assert answer["type"] == "moving", answer
        answer = ask(jog, {"type": "stop", "reason": "released"})
        assert answer["type"] == "stopped", answer
        entries = summarized(stack)
    finally:
        stack.in_sim(lambda c: setattr(c.model.channels[0], "servo", False))
    jogs = [e for e in entries if "Jog" in e["what"] or e["what"].startswith("jog")]
    assert len(jogs) == 1, jogs
    (summary,) = jogs
    assert summary["what"].startswith("jog channel 1 axis 4 + (joint): started ")
    assert " UTC, " in summary["what"] and "axis 4 moved" in summary["what"]
    assert summary["outcome"] == "stopped: released"


async def _hold(stack: Stack, who: Who) -> None:
    stack.line.lease.acquire(who, 300.0)


def test_a_refused_jog_start_is_recorded_by_the_line(stack: Stack, jog: Any) -> None:
    stack.call(_hold(stack, Who("mes", "mqtt")))
    answer = ask(jog, {"type": "start", "channel": 1, "axis": 4, "direction": "+"})
    assert answer["type"] == "error" and "held by mes (mqtt)" in answer["error"]
    (refused,) = [e for e in olga_entries(stack) if e["what"].startswith("JogStart(")]
    assert refused["outcome"].startswith("refused: ")
