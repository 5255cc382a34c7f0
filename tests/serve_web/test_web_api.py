"""The dashboard over HTTP: pages for everyone, state changes only with a role, a CSRF token and
a confirmation, every one of them through the line server (lease and audit)."""

from __future__ import annotations

import json
import time

import httpx
import pytest
from web_harness import Stack, csrf_of, login

from robostar.commands.files import DownloadFile, FileExists
from robostar.commands.io import ReadOutputs
from robostar.protocol.fields import FileName
from robostar.types import CoordSystem


def test_pages_are_read_only_for_everyone(stack: Stack, client: httpx.Client) -> None:
    for path in ("/", "/line/cell1", "/line/cell1/files", "/line/cell1/jog", "/audit", "/health"):
        page = client.get(path)
        assert page.status_code == 200, path
        assert "read-only" in page.text
    assert "cell1" in client.get("/").text


def test_no_default_user_and_wrong_passwords_are_refused(client: httpx.Client) -> None:
    token = csrf_of(client.get("/login").text)
    for user, password in (("admin", "admin"), ("olga", "wrong-password")):
        answer = client.post(
            "/login", data={"csrf_token": token, "username": user, "password": password}
        )
        assert "Wrong name or password" in answer.text


def test_login_is_rate_limited(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=10.0) as http:
        token = csrf_of(http.get("/login").text)
        texts = [
            http.post(
                "/login", data={"csrf_token": token, "username": "mallory", "password": "nope-nope"}
            ).text
            for _ in range(6)
        ]
    assert "Too many attempts" in texts[-1]


def test_a_state_change_needs_csrf_role_and_confirmation(stack: Stack) -> None:
    body = {"action": "servo", "channel": 1, "on": True, "confirmed": True}
    with httpx.Client(base_url=stack.url, timeout=10.0) as http:
        token = csrf_of(http.get("/").text)
        # anonymous, with the right token: no role
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 403
        token = login(http, "vic")
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 403 and "operator" in answer.json()["error"]
    with httpx.Client(base_url=stack.url, timeout=10.0) as http:
        token = login(http, "olga")
        forged = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": "forged"})
        assert forged.status_code == 403 and "CSRF" in forged.json()["error"]
        unconfirmed = {**body, "confirmed": False}
        answer = http.post("/line/cell1/action", json=unconfirmed, headers={"x-csrf-token": token})
        assert answer.status_code == 428
    assert not stack.in_sim(lambda c: c.model.channels[0].servo)


def test_an_operator_switches_the_servo_and_it_is_audited(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        token = login(http, "olga")
        body = {"action": "servo", "channel": 1, "on": True, "confirmed": True}
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 200, answer.text
        assert stack.in_sim(lambda c: c.model.channels[0].servo)
        body["on"] = False
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 200, answer.text
        # each click took control for itself only and gave it back: nothing left to release
        released = http.post("/line/cell1/release", headers={"x-csrf-token": token})
        assert released.json() == {"ok": True, "released": False}
    assert stack.line.lease.holder is None
    assert not stack.in_sim(lambda c: c.model.channels[0].servo)
    entries = [json.loads(text) for text in stack.audit_path.read_text().splitlines()]
    servo = [e for e in entries if e["what"].startswith("Servo(") and e["who"] == "olga"]
    assert len(servo) >= 2


def test_an_operator_switches_an_output(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=10.0) as http:
        token = login(http, "olga")
        body = {"action": "output", "port": 1, "contact": 12, "on": True, "confirmed": True}
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 200, answer.text
    outputs = stack.call(stack.line.read(ReadOutputs(1), max_age=0))
    assert outputs.contacts[12]


def test_bad_action_values_are_refused_before_the_line(stack: Stack) -> None:
    before = sum(stack.in_sim(lambda c: dict(c.executions)).values())
    with httpx.Client(base_url=stack.url, timeout=10.0) as http:
        token = login(http, "olga")
        for body in (
            {"action": "speed", "channel": 1, "speed": 5000, "confirmed": True},
            {"action": "output", "port": 9, "contact": 1, "on": True, "confirmed": True},
            {"action": "servo", "channel": 4, "on": True, "confirmed": True},
            {"action": "launch_missiles", "confirmed": True},
        ):
            answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
            assert answer.status_code == 400, body
    assert sum(stack.in_sim(lambda c: dict(c.executions)).values()) == before


def test_upload_shows_a_preview_then_writes_only_when_confirmed(stack: Stack) -> None:
    job = "MAIN\nMOVJ P0001\nEOP\n"
    name = FileName.parse("WEB1.JOB")
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        token = login(http, "erin")
        preview = http.post(
            "/line/cell1/files/upload",
            data={"csrf_token": token, "channel": "1", "name": "WEB1.JOB", "job_number": "7"},
            files={"file": ("web1.job", job.encode("ascii"), "text/plain")},
        )
        assert preview.status_code == 200, preview.text
        assert "MOVJ P0001" in preview.text and "Nothing has been written yet" in preview.text
        assert not stack.call(stack.line.read(FileExists(1, name)))
        done = http.post(
            "/line/cell1/files/upload/confirm",
            data={
                "csrf_token": token,
                "channel": "1",
                "name": "WEB1.JOB",
                "job_number": "7",
                "content": job,
                "confirmed": "yes",
            },
            follow_redirects=False,
        )
        assert done.status_code == 303, done.text
    assert stack.call(stack.line.read(FileExists(1, name)))


def test_an_operator_may_not_upload(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=10.0) as http:
        token = login(http, "olga")
        answer = http.post(
            "/line/cell1/files/upload",
            data={"csrf_token": token, "channel": "1", "name": "X.JOB"},
            files={"file": ("x.job", b"MAIN\nEOP\n", "text/plain")},
        )
        assert answer.status_code == 403


def test_the_event_stream_carries_a_change_from_the_controller(stack: Stack) -> None:
    with (
        httpx.Client(base_url=stack.url, timeout=10.0) as http,
        http.stream("GET", "/events") as stream,
    ):
        stack.in_sim(lambda c: c.model.set_input(2, 3, True))
        deadline = time.monotonic() + 10
        for line in stream.iter_lines():
            if line.startswith("data:"):
                change = json.loads(line[5:])
                if change["key"] == "io/in/2" and change["value"]["contacts"][3]:
                    break
            assert time.monotonic() < deadline
    stack.in_sim(lambda c: c.model.set_input(2, 3, False))


@pytest.mark.parametrize("path", ["/line/nowhere", "/line/cell1/files/1/BAD NAME.JOB"])
def test_unknown_things_are_not_found(client: httpx.Client, path: str) -> None:
    assert client.get(path).status_code in (400, 404)


def test_an_engineer_changes_a_point_of_a_point_file(stack: Stack) -> None:
    name = FileName.parse("DEMO.PNT")
    before = stack.call(stack.line.read(DownloadFile(1, name, CoordSystem.ANGLE), max_age=0))
    count = len(before.points[1].axes)
    axes = {f"axis{i}": str(10.5 + i) for i in range(1, count + 1)}
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        token = login(http, "erin")
        path = "/line/cell1/files/1/DEMO.PNT/point"
        unconfirmed = http.post(path, data={"csrf_token": token, "number": "1", **axes})
        assert unconfirmed.status_code == 428
        too_fine = {**axes, "axis1": "1.0004"}
        refused = http.post(
            path, data={"csrf_token": token, "number": "1", "confirmed": "yes", **too_fine}
        )
        assert refused.status_code == 400 and "3 decimals" in refused.json()["error"]
        done = http.post(
            path,
            data={"csrf_token": token, "number": "1", "confirmed": "yes", **axes},
            follow_redirects=False,
        )
        assert done.status_code == 303, done.text
    after = stack.call(stack.line.read(DownloadFile(1, name, CoordSystem.ANGLE), max_age=0))
    assert after.points[1].axes == tuple(10.5 + i for i in range(1, count + 1))
    assert {n: p for n, p in after.points.items() if n != 1} == {
        n: p for n, p in before.points.items() if n != 1
    }


def test_variables_page_reads_fresh_and_an_engineer_writes_with_confirmation(stack: Stack) -> None:
    stack.in_sim(lambda c: c.model.ints.update({3: 4321}))
    stack.in_sim(lambda c: c.model.floats.update({2: 12.5}))
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        page = http.get("/line/cell1/variables?kind=int&start=0&count=5")
        assert page.status_code == 200 and "4321" in page.text
        assert "12.500" in http.get("/line/cell1/variables?kind=float&count=3").text
        assert "unused" in http.get("/line/cell1/variables?kind=point&count=2").text
        assert http.get("/line/cell1/variables?kind=bogus").status_code == 400
        token = csrf_of(page.text)
        form = {"csrf_token": token, "kind": "int", "index": "3", "value": "7", "confirmed": "yes"}
        anonymous = http.post("/line/cell1/variables", data=form)
        assert anonymous.status_code == 403
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        token = login(http, "olga")  # an operator may not write variables
        form = {"csrf_token": token, "kind": "int", "index": "3", "value": "7", "confirmed": "yes"}
        assert http.post("/line/cell1/variables", data=form).status_code == 403
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        token = login(http, "erin")
        base = {"csrf_token": token, "kind": "int", "index": "3"}
        unconfirmed = http.post("/line/cell1/variables", data={**base, "value": "7"})
        assert unconfirmed.status_code == 428
        for kind, bad, rule in (
            ("int", "1.5", "whole number"),
            ("int", "1000000", "not in"),
            ("float", "nan", "does not fit"),
            ("float", "1.0004", "3 decimals"),
        ):
            form = {**base, "kind": kind, "value": bad, "confirmed": "yes"}
            refused = http.post("/line/cell1/variables", data=form)
            assert refused.status_code == 400 and rule in refused.json()["error"], (kind, bad)
        done = http.post(
            "/line/cell1/variables",
            data={**base, "value": "-42", "confirmed": "yes"},
            follow_redirects=False,
        )
        assert done.status_code == 303, done.text
        wrote_float = http.post(
            "/line/cell1/variables",
            data={**base, "kind": "float", "index": "2", "value": "-3.25", "confirmed": "yes"},
            follow_redirects=False,
        )
        assert wrote_float.status_code == 303, wrote_float.text
    assert stack.in_sim(lambda c: c.model.ints[3]) == -42
    assert stack.in_sim(lambda c: c.model.floats[2]) == -3.25
    entries = [json.loads(t) for t in stack.audit_path.read_text().splitlines()]
    whats = [e["what"] for e in entries if e["who"] == "erin" and e["face"] == "web"]
    assert any("WriteGlobalInt(index=3, value=-42)" in w for w in whats), whats
    assert any("WriteGlobalFloat(index=2, value=-3.25)" in w for w in whats), whats
