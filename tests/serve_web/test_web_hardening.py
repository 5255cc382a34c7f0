"""The dashboard's guards: DNS rebinding refused, no session outliving a sign-out or its user,
no body read before the guards, every refusal in the audit log, sign-ins from one address under
many names held back, the backup of a two-channel controller, non-ASCII tokens."""

from __future__ import annotations

import asyncio
import io
import json
import socket
import threading
import time
import zipfile
from collections.abc import AsyncIterator, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx
import pytest
from web_harness import PASSWORDS, Stack, csrf_of, login

from robostar.serve.config import LineConfig, ServeConfig
from robostar.serve.faces.web import WebFace
from robostar.serve.line_server import LineServer
from robostar.serve.users import Role, UserStore

SPEED = {"action": "speed", "channel": 1, "speed": 321, "confirmed": True}


@contextmanager
def own_face(stack: Stack, options: dict[str, Any], server: Any = None) -> Iterator[WebFace]:
    """A second dashboard on the stack's loop (its own users, limiter and sessions)."""
    face = WebFace(server or stack.server, {"listen": "127.0.0.1:0", **options})
    stack.call(face.start())
    try:
        yield face
    finally:
        stack.call(face.stop())


def audit_entries(stack: Stack) -> list[dict[str, Any]]:
    return [json.loads(text) for text in stack.audit_path.read_text().splitlines()]


def handshake(url: str, path: str, **headers: str) -> bytes:
    """A WebSocket opening handshake by hand; the status line of the answer."""
    host, port = url.removeprefix("http://").rsplit(":", 1)
    lines = [
        f"GET {path} HTTP/1.1",
        f"Host: {headers.pop('host', f'{host}:{port}')}",
        "Upgrade: websocket",
        "Connection: Upgrade",
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
        "Sec-WebSocket-Version: 13",
        *(f"{k}: {v}" for k, v in headers.items()),
    ]
    with socket.create_connection((host, int(port)), timeout=10) as sock:
        sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
        return sock.makefile("rb").readline()


# -- 1: the Host header ------------------------------------------------------------------------
def test_a_foreign_host_header_is_refused(stack: Stack, client: httpx.Client) -> None:
    port = stack.face.port
    for path in ("/audit", "/line/cell1/backup.zip", "/line/cell1/files", "/"):
        answer = client.get(path, headers={"Host": f"rebind.attacker.example:{port}"})
        assert answer.status_code == 400, path
        assert "cell1" not in answer.text
    for host in (f"localhost:{port}", f"127.0.0.1:{port}"):
        assert client.get("/", headers={"Host": host}).status_code == 200
    status = handshake(stack.url, "/line/cell1/jog/ws?csrf=x", host="evil.example")
    assert b" 101 " not in status and b" 403 " in status, status


def test_the_hosts_option_names_what_a_proxy_passes_on(stack: Stack) -> None:
    with (
        own_face(stack, {"hosts": ["cell7.plant.example"]}) as face,
        httpx.Client(base_url=face.url, timeout=10) as http,
    ):
        assert http.get("/", headers={"Host": "cell7.plant.example"}).status_code == 200
        assert http.get("/", headers={"Host": "cell8.plant.example"}).status_code == 400


# -- 2: sessions -------------------------------------------------------------------------------
def test_a_signed_out_cookie_replayed_is_anonymous(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=10) as http:
        token = login(http, "olga")
        old = dict(http.cookies)
        assert http.post("/logout", data={"csrf_token": token}).status_code in (200, 303)
    with httpx.Client(base_url=stack.url, timeout=10, cookies=old) as replay:
        answer = replay.post("/line/cell1/action", json=SPEED, headers={"x-csrf-token": token})
        assert answer.status_code == 403, answer.text
        assert "read-only" in replay.get("/").text
    assert stack.line.lease.holder is None


def test_a_removed_user_or_a_lowered_role_counts_from_the_next_request(
    stack: Stack, tmp_path: Path
) -> None:
    path = tmp_path / "users.toml"
    store = UserStore(path)
    store.add("olga", Role.OPERATOR, PASSWORDS["olga"])
    store.add("erin", Role.ENGINEER, PASSWORDS["erin"])
    with own_face(stack, {"users": str(path)}) as face:
        with httpx.Client(base_url=face.url, timeout=10) as olga:
            token = login(olga, "olga")
            UserStore(path).remove("olga")  # what `robostar serve user remove` does
            answer = olga.post("/line/cell1/action", json=SPEED, headers={"x-csrf-token": token})
            assert answer.status_code == 403, answer.text
            assert "read-only" in olga.get("/").text
        with httpx.Client(base_url=face.url, timeout=10) as erin:
            login(erin, "erin")
            assert "erin (engineer)" in erin.get("/").text
            time.sleep(0.05)  # a new modification time for the file
            path.write_text(path.read_text().replace('role = "engineer"', 'role = "viewer"'))
            page = erin.get("/")
            assert "erin (viewer)" in page.text
            token = csrf_of(page.text)
            answer = erin.post("/line/cell1/action", json=SPEED, headers={"x-csrf-token": token})
            assert answer.status_code == 403 and "operator" in answer.json()["error"]
    assert stack.line.lease.holder is None


def test_a_jog_socket_ends_when_its_session_does(stack: Stack) -> None:
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    with httpx.Client(base_url=stack.url, timeout=10) as http:
        token = login(http, "olga")
        cookie = "; ".join(f"{k}={v}" for k, v in http.cookies.items())
        url = stack.url.replace("http://", "ws://") + f"/line/cell1/jog/ws?csrf={token}"
        with connect(url, additional_headers={"Origin": stack.url, "Cookie": cookie}) as socket:
            http.post("/logout", data={"csrf_token": token})
            socket.send(json.dumps({"type": "start", "channel": 1, "axis": 1, "direction": "+"}))
            answer = json.loads(socket.recv(timeout=10))
            assert answer["type"] == "error" and "sign in" in answer["error"], answer
            with pytest.raises(ConnectionClosed):
                socket.recv(timeout=10)
    assert stack.line.lease.holder is None


# -- 3: bodies ---------------------------------------------------------------------------------
def test_an_anonymous_body_is_not_read(stack: Stack, client: httpx.Client) -> None:
    token = csrf_of(client.get("/").text)
    # refused for the role before the body is looked at (it is not even JSON)
    answer = client.post(
        "/line/cell1/action",
        content=b"{not json",
        headers={"x-csrf-token": token, "content-type": "application/json"},
    )
    assert answer.status_code == 403 and "operator" in answer.json()["error"]
    host, port = stack.url.removeprefix("http://").rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=10) as sock:
        sock.sendall(
            f"POST /line/cell1/action HTTP/1.1\r\nHost: {host}:{port}\r\n"
            "Content-Type: application/json\r\nContent-Length: 419430400\r\n\r\n".encode()
        )
        assert b" 413 " in sock.makefile("rb").readline()


def test_a_body_past_the_limit_is_refused(stack: Stack) -> None:
    async def chunks() -> AsyncIterator[bytes]:
        yield b'{"action": "speed", "pad": "'
        for _ in range(8):
            yield b" " * (1 << 20)
        yield b'"}'

    async def post(base: str, cookies: Any, token: str) -> int:
        async with httpx.AsyncClient(base_url=base, cookies=cookies, timeout=30) as http:
            answer = await http.post(
                "/line/cell1/action",
                content=chunks(),
                headers={"x-csrf-token": token, "content-type": "application/json"},
            )
            return answer.status_code

    with httpx.Client(base_url=stack.url, timeout=10) as http:
        token = login(http, "olga")
        assert asyncio.run(post(stack.url, http.cookies, token)) == 413


def test_forms_are_parsed_within_limits(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=30) as http:
        token = login(http, "erin")
        form = {"csrf_token": token, "channel": "1", "name": "TWO.JOB"}
        two_files = http.post(
            "/line/cell1/files/upload",
            data=form,
            files=[
                ("file", ("a.job", b"MAIN\nEOP\n", "text/plain")),
                ("file", ("b.job", b"MAIN\nEOP\n", "text/plain")),
            ],
        )
        assert two_files.status_code == 400, two_files.text
        many = {**form, **{f"f{i}": "x" for i in range(200)}}
        fields = http.post(
            "/line/cell1/files/upload",
            data=many,
            files={"file": ("a.job", b"MAIN\nEOP\n", "text/plain")},
        )
        assert fields.status_code == 400, fields.text


# -- 5: refusals in the audit log --------------------------------------------------------------
def test_refusals_are_audited(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=10) as http:
        token = login(http, "vic")
        body = {"action": "emergency_stop", "confirmed": True}
        answer = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": token})
        assert answer.status_code == 403
    with httpx.Client(base_url=stack.url, timeout=10) as http:
        login(http, "olga")
        body = {"action": "job_start", "channel": 1, "confirmed": True}
        forged = http.post("/line/cell1/action", json=body, headers={"x-csrf-token": "forged"})
        assert forged.status_code == 403
    refused = [e for e in audit_entries(stack) if e["outcome"].startswith("refused")]
    by = {(e["who"], e["face"]): e["outcome"] for e in refused}
    assert "operator" in by[("vic", "web")], refused
    assert "CSRF" in by[("olga", "web")], refused


# -- 6: sign-ins -------------------------------------------------------------------------------
def test_sign_ins_are_limited_per_address_whatever_the_names(stack: Stack) -> None:
    with (
        own_face(stack, {"users": str(stack.face.users.path)}) as face,
        httpx.Client(base_url=face.url, timeout=30) as http,
    ):
        token = csrf_of(http.get("/login").text)
        texts = [
            http.post(
                "/login",
                data={"csrf_token": token, "username": f"u{i}", "password": "nope-nope"},
                headers={"X-Forwarded-For": f"192.0.2.{i}"},  # not a proxy: not believed
            ).text
            for i in range(25)
        ]
        assert "Too many attempts" in texts[-1]
        assert sum("Wrong name or password" in t for t in texts) <= 20


def test_password_checks_run_two_at_a_time(stack: Stack) -> None:
    with own_face(stack, {"users": str(stack.face.users.path)}) as face:
        users = face.users
        real = users.verify
        lock = threading.Lock()
        running = [0, 0]  # now, most at once

        def counted(name: str, password: str) -> Any:
            with lock:
                running[0] += 1
                running[1] = max(running[1], running[0])
            try:
                time.sleep(0.1)
                return real(name, password)
            finally:
                with lock:
                    running[0] -= 1

        users.verify = counted  # type: ignore[method-assign]

        async def many() -> list[str]:
            limits = httpx.Limits(max_connections=50)
            async with httpx.AsyncClient(base_url=face.url, timeout=60, limits=limits) as http:
                token = csrf_of((await http.get("/login")).text)

                async def one(i: int) -> str:
                    data = {"csrf_token": token, "username": f"n{i}", "password": "nope-nope"}
                    return (await http.post("/login", data=data)).text

                return await asyncio.gather(*(one(i) for i in range(12)))

        texts = asyncio.run(many())
        assert all("Wrong name" in t or "Too many" in t for t in texts)
        assert 1 <= running[1] <= 2, running


# -- 7: the backup of a two-channel controller -------------------------------------------------
def test_the_backup_of_a_two_channel_controller(stack: Stack, users_file: Path) -> None:
    config = ServeConfig(
        lines=(LineConfig("cell2", "sim://?channels=2", poll_interval=0.05),), faces={}
    )
    server = LineServer(config)
    stack.call(server.start())
    try:
        stack.call(server.lines["cell2"].wait_polled())
        with (
            own_face(stack, {"users": str(users_file)}, server) as face,
            httpx.Client(base_url=face.url, timeout=30) as http,
        ):
            login(http, "vic")  # a backup needs a signed-in user (a viewer at least)
            answer = http.get("/line/cell2/backup.zip")
            assert answer.status_code == 200, answer.text
            names = zipfile.ZipFile(io.BytesIO(answer.content)).namelist()
            assert not any(n.startswith("ch3/") for n in names), names
            assert "channel 3" not in http.get("/").text
    finally:
        stack.call(server.stop())


# -- 8: non-ASCII tokens -----------------------------------------------------------------------
def test_non_ascii_csrf_tokens_are_refused_not_a_crash(stack: Stack) -> None:
    with httpx.Client(base_url=stack.url, timeout=10) as http:
        login(http, "olga")
        answer = http.post("/line/cell1/action", json=SPEED, headers=[(b"x-csrf-token", b"\xe9")])
        assert answer.status_code == 403
        token = csrf_of(http.get("/").text)
        form = http.post("/line/cell1/release", data={"csrf_token": "\u00e9t\u00e9"})
        assert form.status_code == 403
        cookie = "; ".join(f"{k}={v}" for k, v in http.cookies.items())
        status = handshake(
            stack.url,
            "/line/cell1/jog/ws?csrf=%C3%A9",
            Origin=stack.url,
            Cookie=cookie,
        )
        assert b" 403 " in status, status
        good = handshake(
            stack.url, f"/line/cell1/jog/ws?csrf={token}", Origin=stack.url, Cookie=cookie
        )
        assert b" 101 " in good, good


@pytest.fixture(autouse=True)
def _no_lease_left(stack: Stack) -> Iterator[None]:
    yield
    holder = stack.line.lease.holder
    if holder is not None:
        stack.loop.call_soon_threadsafe(stack.line.lease.release, holder.who)
