"""The MQTT face's commands under abuse: every refusal answered and audited, a response topic
that cannot be published to, payloads that are not parameters, and a flood of commands
(bounded per line, refused as busy past the bound, state reporting still flowing)."""

from __future__ import annotations

import asyncio
import gc
import json
from pathlib import Path
from typing import Any

import pytest

from robostar.commands.control import ReadSpeed
from robostar.serve.faces.mqtt.commands import read_params
from robostar.serve.faces.mqtt.topics import response_topic_problem

from .conftest import RESULTS, Broker, Requester, serving, until

pytestmark = pytest.mark.timeout(180)


def _audit(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines()]


class LostTaskErrors:
    """Catches what asyncio reports about tasks that died with an exception nobody retrieved."""

    def __init__(self) -> None:
        self.reports: list[dict[str, Any]] = []

    def install(self) -> None:
        asyncio.get_running_loop().set_exception_handler(lambda _, ctx: self.reports.append(ctx))

    def check(self) -> None:
        gc.collect()
        assert self.reports == []


def test_a_response_topic_with_a_wildcard_is_refused_before_the_command_runs(
    broker: Broker, tmp_path: Path
) -> None:
    audit = tmp_path / "audit.jsonl"
    lost = LostTaskErrors()

    async def main() -> None:
        lost.install()
        async with serving(broker, audit) as (server, _):
            async with Requester.connect(broker) as req:
                for n, topic in enumerate(("replies/#", "replies/+/me", "$SYS/me", ""), 1):
                    body = {"channel": 1, "value": 77, "id": n}
                    await req.send(
                        "speed", json.dumps(body).encode(), response_topic=topic, correlation=b"c"
                    )
                    await until(lambda: req.by_id(n) != [])  # noqa: B023
                    [(where, reply, corr)] = req.by_id(n)
                    # Refused, answered on the default result topic, with the correlation data.
                    assert where == "robostar/cell1/cmd/speed/result"
                    assert reply["ok"] is False and "response topic" in reply["error"]
                    assert corr == b"c"
                speed = await server.lines["cell1"].read(ReadSpeed(1), max_age=0)
                assert speed != 77  # nothing ran
                # A good response topic still works.
                body = {"channel": 1, "value": 66, "id": "ok"}
                await req.send(
                    "speed",
                    json.dumps(body).encode(),
                    response_topic="replies/me",
                    correlation=b"d",
                )
                await until(lambda: req.by_id("ok") != [])
                [(where, reply, corr)] = req.by_id("ok")
                assert (where, reply, corr) == (
                    "replies/me",
                    {"ok": True, "result": None, "id": "ok"},
                    b"d",
                )
            workers = server.faces["mqtt"].links["cell1"].workers  # type: ignore[attr-defined]
            assert workers and not any(w.done() for w in workers)
        refusals = [e for e in _audit(audit) if e["outcome"].startswith("refused")]
        assert len(refusals) == 4
        assert all(
            e["face"] == "mqtt" and e["who"] == "cell-robostar" and "response topic" in e["outcome"]
            for e in refusals
        )
        lost.check()

    asyncio.run(main())


def test_payloads_that_are_not_parameters_get_a_bad_payload_reply(
    broker: Broker, tmp_path: Path
) -> None:
    audit = tmp_path / "audit.jsonl"
    lost = LostTaskErrors()
    payloads = {
        "deep-over-cap": b"[" * 60_000,  # over max_payload, within the packet size
        "deep-within-cap": b"[" * 5_000,
        "deep-object": b'{"a":' * 5_000,
        "not-utf8": b"\xff\xfe{",
        "not-an-object": b"[1, 2]",
        "truncated": b'{"channel": 1',
    }

    async def main() -> None:
        lost.install()
        async with serving(broker, audit), Requester.connect(broker) as req:
            for n, payload in enumerate(payloads.values()):
                # The payload carries no id: correlation data tells the replies apart.
                await req.send("speed", payload, correlation=str(n).encode())
                await until(lambda: any(r[2] == str(n).encode() for r in req.replies))  # noqa: B023
            for n, name in enumerate(payloads):
                [(_, reply, _)] = [r for r in req.replies if r[2] == str(n).encode()]
                assert reply["ok"] is False, name
                assert reply["error"].startswith("bad payload"), (name, reply)
                assert reply["kind"] == "UsageError"
            # The face still takes commands.
            await req.send("speed", b'{"channel": 1, "value": 12, "id": "after"}')
            await until(lambda: req.by_id("after") != [])
            assert req.by_id("after")[0][1]["ok"] is True
        refusals = [e for e in _audit(audit) if e["outcome"].startswith("refused: bad payload")]
        assert len(refusals) == len(payloads)
        assert "over the limit" in refusals[0]["outcome"]
        lost.check()

    asyncio.run(main())


def test_allowlist_and_parameter_refusals_are_audited(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with serving(broker, audit), Requester.connect(broker) as req:
            await req.send("output", b'{"port": 1, "contact": 1, "on": true, "id": 1}')
            await req.send("speed", b'{"channel": 1, "value": 5000, "id": 2}')
            await req.send("speed", b'{"channel": "one", "value": 5, "id": 3}')
            await req.send("fly", b'{"id": 4}')
            await until(lambda: all(req.by_id(n) for n in (1, 2, 3, 4)))
            assert all(not req.by_id(n)[0][1]["ok"] for n in (1, 2, 3, 4))
        entries = _audit(audit)
        assert all(e["face"] == "mqtt" and e["who"] == "cell-robostar" for e in entries)
        outcomes = sorted((e["what"], e["outcome"]) for e in entries)  # refused in any order
        assert len(outcomes) == 4, outcomes
        assert all(outcome.startswith("refused: ") for _, outcome in outcomes)
        (w1, o1), (w2, o2), (w3, o3), (w4, o4) = outcomes
        assert w1.startswith("SetSpeed") and "5000" in o1
        assert w2 == "cmd/fly" and "unknown command" in o2  # not one the face has
        assert w3 == "cmd/output" and "not enabled" in o3
        assert w4 == "cmd/speed" and "channel" in o4

    asyncio.run(main())


def test_an_audit_log_that_fails_does_not_end_the_reader(broker: Broker, tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        async with serving(broker, audit) as (server, link):
            line = server.lines["cell1"]
            real = line.record

            def record(what: Any, who: Any, outcome: str) -> None:
                if outcome.startswith("refused"):
                    raise OSError("disk full")
                real(what, who, outcome)

            line.record = record  # type: ignore[method-assign]
            async with Requester.connect(broker) as req:
                await req.send("output", b'{"id": 1}')  # refused by the reader itself
                await until(lambda: req.by_id(1) != [])
                await req.send("speed", b'{"channel": 1, "value": 21, "id": 2}')
                await until(lambda: req.by_id(2) != [])
                assert req.by_id(1)[0][1]["ok"] is False and req.by_id(2)[0][1]["ok"] is True
            assert link.client is not None

    asyncio.run(main())


def test_a_full_command_queue_refuses_busy_but_stops_have_their_own(
    broker: Broker, tmp_path: Path
) -> None:
    audit = tmp_path / "audit.jsonl"

    async def main() -> None:
        commands = {"allow": ["speed", "stop_job"], "estop": True, "max_pending": 3}
        async with (
            serving(broker, audit, **commands) as (_, link),
            Requester.connect(broker) as req,
        ):
            link.lanes["commands"].pending = 3  # as if three commands waited
            await req.send("speed", b'{"channel": 1, "value": 9, "id": "busy"}')
            await req.send("estop", b'{"id": "estop"}')
            await until(lambda: req.by_id("busy") != [] and req.by_id("estop") != [])
            busy = req.by_id("busy")[0][1]
            assert busy["ok"] is False and busy["kind"] == "BusyError"
            assert busy["error"].startswith("busy")
            assert req.by_id("estop")[0][1]["ok"] is True
            link.lanes["commands"].pending = 0
            await req.send("speed", b'{"channel": 1, "value": 9, "id": "later"}')
            await until(lambda: req.by_id("later") != [])
            assert req.by_id("later")[0][1]["ok"] is not None
        entries = _audit(audit)
        busy_entries = [e for e in entries if e["outcome"].startswith("refused: busy")]
        assert len(busy_entries) == 1 and busy_entries[0]["who"] == "cell-robostar"
        assert any("EmergencyStop" in e["what"] and e["outcome"] == "ok" for e in entries)

    asyncio.run(main())


def test_a_command_flood_is_bounded_and_state_keeps_flowing(broker: Broker, tmp_path: Path) -> None:
    """The reviewer's flood: thousands of commands as fast as a client can send them. The face
    runs at most ``max_pending`` per line, answers the rest busy (audited), holds no task per
    message, and the line's values keep going out meanwhile."""
    audit = tmp_path / "audit.jsonl"
    count = 3000

    async def main() -> None:
        async with serving(broker, audit, max_pending=4) as (server, link):
            face = server.faces["mqtt"]
            line = server.lines["cell1"]
            async with Requester.connect(broker, RESULTS, "robostar/cell1/test/#") as req:
                baseline = len(face.tasks)  # type: ignore[attr-defined]
                peaks = {"tasks": 0, "pending": 0, "queue": 0}
                seen_marks: list[int] = []

                async def watch() -> None:
                    while True:
                        peaks["tasks"] = max(peaks["tasks"], len(face.tasks))  # type: ignore[attr-defined]
                        peaks["pending"] = max(peaks["pending"], link.lanes["commands"].pending)
                        peaks["queue"] = max(peaks["queue"], line.queue_depth)
                        await asyncio.sleep(0.002)

                async def marks() -> None:
                    # State reporting during the flood: a model value set now must arrive.
                    for k in range(1, 6):
                        line.model.set("test/mark", k)
                        await until(lambda: k in seen_marks, 10)  # noqa: B023
                        await asyncio.sleep(0.1)

                def collect_marks() -> None:
                    for topic, body, _ in req.replies:
                        if topic == "robostar/cell1/test/mark" and body["value"] not in seen_marks:
                            seen_marks.append(body["value"])

                watcher = asyncio.create_task(watch())
                pad = "x" * 1000
                for n in range(count):
                    body = {"channel": 1, "value": 5 + n % 100, "id": n, "pad": pad}
                    await req.send("speed", json.dumps(body).encode(), qos=0)
                    if n == 200:
                        marker = asyncio.create_task(marks())
                    if n % 50 == 0:
                        collect_marks()
                        await asyncio.sleep(0)
                while not marker.done():
                    collect_marks()
                    await asyncio.sleep(0.02)
                marker.result()  # every value arrived while commands were refused
                # The flood drains at once: nothing stale keeps running for seconds.
                await until(lambda: link.lanes["commands"].pending == 0, 5)
                await asyncio.sleep(0.5)
                watcher.cancel()
                replies = [body for topic, body, _ in req.replies if topic.endswith("/result")]
            assert peaks["pending"] <= 4
            assert peaks["tasks"] <= baseline
            assert peaks["queue"] <= 4 + 4  # the face's bound, and the poller's reads
            busy = [r for r in replies if r.get("kind") == "BusyError"]
            done = [r for r in replies if r["ok"] is True]
            assert busy and done, (len(busy), len(done))
            assert all(r["error"].startswith("busy") for r in busy)
            assert len({r["id"] for r in replies}) == len(replies)  # one answer per request
        entries = _audit(audit)
        refused = [e for e in entries if e["outcome"].startswith("refused: busy")]
        # Every busy answer was audited (the broker may drop answers to a subscriber that falls
        # behind, never audit entries), and nothing was recorded twice.
        assert len(refused) >= len(busy)
        assert all(e["who"] == "cell-robostar" and e["face"] == "mqtt" for e in refused)
        assert len(entries) <= count

    asyncio.run(main())


def test_the_client_queue_of_incoming_messages_is_bounded() -> None:
    from robostar.serve.faces.mqtt import MqttFace, settings_from

    async def main() -> int:
        face = MqttFace(None, settings_from({"url": "mqtt://127.0.0.1"}))  # type: ignore[arg-type]
        return face.client("x", "robostar/x/online")._queue.maxsize

    assert 0 < asyncio.run(main()) <= 1000


# -- pure parts -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("topic", "problem"),
    [
        ("replies/me", None),
        ("a", None),
        ("", "empty"),
        ("replies/#", "wildcard"),
        ("replies/+/me", "wildcard"),
        ("$SYS/x", "$"),
        ("a\x00b", "NUL"),
        ("a" * 65_536, "65,535"),
    ],
)
def test_response_topics_are_checked(topic: str, problem: str | None) -> None:
    found = response_topic_problem(topic)
    if problem is None:
        assert found is None
    else:
        assert found is not None and problem in found


def test_read_params_never_raises_anything_but_a_usage_error() -> None:
    from robostar.errors import UsageError

    for payload in (b"[" * 100_000, b'{"a":' * 50_000, b"\xff", b"1e999999", b"[]"):
        with pytest.raises(UsageError, match="bad payload"):
            read_params(payload)


@pytest.mark.parametrize(
    ("commands", "key"),
    [
        ({"max_pending": 0}, "max_pending"),
        ({"max_pending": "8"}, "max_pending"),
        ({"max_payload": 4}, "max_payload"),
        ({"max_payload": True}, "max_payload"),
        ({"max_queue": 8}, "max_queue"),
    ],
)
def test_bad_command_limits_are_refused_naming_the_key(commands: dict[str, Any], key: str) -> None:
    from robostar.errors import UsageError
    from robostar.serve.faces.mqtt import settings_from

    with pytest.raises(UsageError, match=f"mqtt.commands.{key}"):
        settings_from({"url": "mqtt://h", "commands": {"enabled": True, **commands}})
    defaults = settings_from({"url": "mqtt://h"})
    assert (defaults.max_pending, defaults.max_payload) == (16, 16_384)


def test_a_full_client_queue_is_logged_once_in_a_while() -> None:
    import logging

    from robostar.serve.faces.mqtt import QueueFullFilter

    shown = QueueFullFilter(every=3600)

    def record(message: str) -> logging.LogRecord:
        return logging.LogRecord("x", logging.WARNING, __file__, 1, message, (), None)

    full = "Message queue is full. Discarding message."
    assert [shown.filter(record(full)) for _ in range(5)] == [True, False, False, False, False]
    assert shown.held == 4 and shown.filter(record("something else"))
    shown._next = 0.0
    again = record(full)
    assert shown.filter(again) and "4 more" in again.getMessage() and shown.held == 0
