"""Uploads as large as the N1 protocol carries, through the real web face to a simulator line:
the largest legitimate JOB goes through, anything larger is refused with a 413 naming the limit,
and nothing reaches the line; every other route keeps a tight body limit."""

from __future__ import annotations

import json
import socket
from typing import Any

import httpx
import pytest
from web_harness import Stack, login

from robostar.commands.files import LINE_MAX
from robostar.commands.job import MAX_STEP
from robostar.protocol.fields import FileName
from robostar.serve.faces.web.limits import DEFAULT_MAX_BODY, MAX_UPLOAD, MAX_UPLOAD_BODY


def _job(steps: int, width: int, end: str = "\r\n") -> bytes:
    """A JOB of ``steps`` lines of ``width`` characters each (no trailing spaces)."""
    lines = [f"{n:04d} MOVJ P{n % 10000:04d} S=50 '".ljust(width, "x") for n in range(steps)]
    return "".join(line + end for line in lines).encode("ascii")


def _stored(stack: Stack, name: str) -> list[str] | None:
    def read(controller: Any) -> list[str] | None:
        stored = controller.model.channel(1).files.get(FileName.parse(name))
        return None if stored is None else list(stored.lines)

    result: list[str] | None = stack.in_sim(read)
    return result


def _uploads(stack: Stack) -> int:
    return int(stack.in_sim(lambda c: c.executions["FB"]))


def _upload_audited(stack: Stack, name: str) -> bool:
    entries = [json.loads(text) for text in stack.audit_path.read_text().splitlines()]
    return any(name in e["what"] and e["what"].startswith("UploadFile") for e in entries)


def _preview(http: httpx.Client, token: str, name: str, raw: bytes) -> httpx.Response:
    return http.post(
        "/line/cell1/files/upload",
        data={"csrf_token": token, "channel": "1", "name": name, "job_number": "9"},
        files={"file": (name.lower(), raw, "text/plain")},
    )


def test_the_limit_is_the_largest_job_the_protocol_carries() -> None:
    # 9999 steps, each a content field of at most 100 bytes with its newline, a CR LF end
    assert MAX_UPLOAD == MAX_STEP * (LINE_MAX + 1) == 1_009_899
    assert MAX_UPLOAD < MAX_UPLOAD_BODY <= MAX_UPLOAD + 64 * 1024
    assert DEFAULT_MAX_BODY == 64 * 1024  # every other route stays tight


def test_the_largest_legitimate_job_is_previewed_and_written(full_stack: Stack) -> None:
    stack = full_stack
    raw = _job(MAX_STEP, LINE_MAX - 1)  # 99 characters and CR LF: the largest there is
    assert len(raw) == MAX_UPLOAD
    before = _uploads(stack)
    with httpx.Client(base_url=stack.url, timeout=120.0) as http:
        token = login(http, "erin")
        preview = _preview(http, token, "BIG.JOB", raw)
        assert preview.status_code == 200, preview.text[:300]
        assert f"{MAX_STEP} lines" in preview.text
        assert _stored(stack, "BIG.JOB") is None  # nothing written by a preview
        # confirmed as the preview page's form sends it: multipart, the content as it is
        # (a browser turns the hidden field's line ends into CR LF)
        content = raw.decode("ascii")
        done = http.post(
            "/line/cell1/files/upload/confirm",
            files={
                "csrf_token": (None, token),
                "channel": (None, "1"),
                "name": (None, "BIG.JOB"),
                "job_number": (None, "9"),
                "content": (None, content),
                "confirmed": (None, "yes"),
            },
            follow_redirects=False,
        )
        assert done.status_code == 303, done.text[:300]
    assert _stored(stack, "BIG.JOB") == raw.decode("ascii").splitlines()
    assert _uploads(stack) == before + 1


def test_a_file_one_byte_over_is_refused_naming_the_limit(full_stack: Stack) -> None:
    stack = full_stack
    raw = _job(MAX_STEP, LINE_MAX - 1) + b"x"
    assert len(raw) == MAX_UPLOAD + 1
    before = _uploads(stack)
    with httpx.Client(base_url=stack.url, timeout=60.0) as http:
        token = login(http, "erin")
        answer = _preview(http, token, "OVER.JOB", raw)
        assert answer.status_code == 413, answer.text[:300]
        message = answer.json()["error"]
        assert f"over {MAX_UPLOAD} bytes" in message and f"{MAX_STEP} steps" in message
        # the confirm route holds its content to the same figure (a form made by hand)
        content = raw.decode("ascii")
        answer = http.post(
            "/line/cell1/files/upload/confirm",
            files={
                "csrf_token": (None, token),
                "channel": (None, "1"),
                "name": (None, "OVER.JOB"),
                "content": (None, content),
                "confirmed": (None, "yes"),
            },
        )
        assert answer.status_code == 413, answer.text[:300]
        assert f"over {MAX_UPLOAD} bytes" in answer.json()["error"]
    assert _stored(stack, "OVER.JOB") is None
    assert _uploads(stack) == before
    assert not _upload_audited(stack, "OVER.JOB")


def test_a_body_past_the_upload_limit_is_refused_before_it_is_read(full_stack: Stack) -> None:
    stack = full_stack
    before = _uploads(stack)
    with httpx.Client(base_url=stack.url, timeout=10.0) as http:
        token = login(http, "erin")
        cookie = "; ".join(f"{k}={v}" for k, v in http.cookies.items())
    host, port = stack.url.removeprefix("http://").rsplit(":", 1)
    for path in ("/line/cell1/files/upload", "/line/cell1/files/upload/confirm"):
        with socket.create_connection((host, int(port)), timeout=10) as sock:
            sock.sendall(  # a length past the limit, and no body: the answer comes first
                f"POST {path} HTTP/1.1\r\nHost: {host}:{port}\r\nCookie: {cookie}\r\n"
                f"X-CSRF-Token: {token}\r\nContent-Type: multipart/form-data; boundary=b\r\n"
                f"Content-Length: {MAX_UPLOAD_BODY + 1}\r\nConnection: close\r\n\r\n".encode()
            )
            answer = sock.makefile("rb").read()
        head, _, body = answer.partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 413 "), head
        assert f"over {MAX_UPLOAD} bytes".encode() in body, body
    assert _uploads(stack) == before


def test_a_job_of_more_steps_than_a_controller_holds_is_refused(stack: Stack) -> None:
    before = _uploads(stack)
    with httpx.Client(base_url=stack.url, timeout=60.0) as http:
        token = login(http, "erin")
        answer = _preview(http, token, "LONG.JOB", _job(MAX_STEP + 1, 8, "\n"))
        assert answer.status_code == 400, answer.text[:300]
        assert f"at most {MAX_STEP}" in answer.json()["error"]
    assert _stored(stack, "LONG.JOB") is None and _uploads(stack) == before


@pytest.mark.parametrize(
    "path", ["/line/cell1/action", "/line/cell1/variables", "/login", "/line/cell1/files"]
)
def test_other_routes_keep_the_tight_limit(stack: Stack, path: str) -> None:
    with httpx.Client(base_url=stack.url, timeout=10.0) as http:
        token = login(http, "erin")
        answer = http.post(
            path,
            content=b"x" * (DEFAULT_MAX_BODY + 1),
            headers={"x-csrf-token": token, "content-type": "application/json"},
        )
        assert answer.status_code == 413, answer.text[:300]
        assert f"over {DEFAULT_MAX_BODY} bytes" in answer.json()["error"]
