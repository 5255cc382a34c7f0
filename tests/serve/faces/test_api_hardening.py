"""The API face against a hostile web page and bad input: cross-site requests, DNS rebinding,
huge bodies, unbounded leases, and values that used to end in a 500."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator, Awaitable, Callable
from pathlib import Path
from typing import Any

import httpx

from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.line import MAX_QUEUED_READS

SET_SPEED = {"command": "SetSpeed", "args": {"channel": 1, "speed": 123}, "implicit_lease": True}


def _run(
    test: Callable[[LineServer, str, httpx.AsyncClient], Awaitable[None]],
    *,
    api: dict[str, Any] | None = None,
    audit: Path | None = None,
    lease_ttl: float = 30.0,
) -> None:
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.05),),
        faces={"api": {"listen": "127.0.0.1:0", **(api or {})}},
        audit_path=str(audit) if audit is not None else None,
        lease_ttl=lease_ttl,
    )

    async def main() -> None:
        async with LineServer(config) as server:
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            async with httpx.AsyncClient(timeout=10) as http:
                await test(server, f"http://{host}:{port}", http)

    asyncio.run(main())


async def _speed(base: str, http: httpx.AsyncClient) -> int:
    read = {"command": "ReadSpeed", "args": {"channel": 1}, "max_age": 0}
    answer = await http.post(f"{base}/lines/cell1/commands", json=read)
    assert answer.status_code == 200, answer.text
    result: int = answer.json()["result"]
    return result


def test_a_web_pages_text_plain_post_is_refused_and_audited(tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"

    async def test(server: LineServer, base: str, http: httpx.AsyncClient) -> None:
        before = await _speed(base, http)
        # a browser's "simple request": text/plain needs no preflight, and it names its origin
        answer = await http.post(
            f"{base}/lines/cell1/commands",
            content=json.dumps(SET_SPEED),
            headers={"Content-Type": "text/plain;charset=UTF-8", "Origin": "https://evil.example"},
        )
        assert answer.status_code in (403, 415), answer.text
        # the same without an Origin (an old browser, a form): still not JSON, still refused
        answer = await http.post(
            f"{base}/lines/cell1/commands",
            content=json.dumps(SET_SPEED),
            headers={"Content-Type": "text/plain"},
        )
        assert answer.status_code == 415, answer.text
        form = await http.post(f"{base}/lines/cell1/lease", data={"x": "1"})
        assert form.status_code == 415
        assert server.lines["cell1"].lease.holder is None
        assert await _speed(base, http) == before != 123

    _run(test, audit=audit)
    entries = [json.loads(text) for text in audit.read_text().splitlines()]
    refused = [e for e in entries if e["outcome"].startswith("refused")]
    assert refused and all(e["face"] == "api" for e in refused)
    assert not any(e["what"].startswith("SetSpeed") for e in entries)


def test_a_foreign_origin_is_refused_even_with_json() -> None:
    async def test(server: LineServer, base: str, http: httpx.AsyncClient) -> None:
        for origin in ("https://evil.example", "null", "http://127.0.0.1:1"):
            answer = await http.post(
                f"{base}/lines/cell1/commands", json=SET_SPEED, headers={"Origin": origin}
            )
            assert answer.status_code == 403, (origin, answer.text)
            assert (await http.get(f"{base}/lines", headers={"Origin": origin})).status_code == 403
        assert server.lines["cell1"].lease.holder is None
        # the API's own origin (a page the API served, were there one) is fine
        own = await http.post(
            f"{base}/lines/cell1/commands", json=SET_SPEED, headers={"Origin": base}
        )
        assert own.status_code == 200, own.text

    _run(test)


def test_a_foreign_host_header_is_refused() -> None:
    async def test(server: LineServer, base: str, http: httpx.AsyncClient) -> None:
        port = base.rsplit(":", 1)[1]
        for host in (f"evil.example:{port}", "evil.example", "127.0.0.1.evil.example", ""):
            answer = await http.get(f"{base}/lines", headers={"Host": host})
            assert answer.status_code == 400, host
        for host in (f"localhost:{port}", f"127.0.0.1:{port}", "LOCALHOST"):
            assert (await http.get(f"{base}/lines", headers={"Host": host})).status_code == 200
        answer = await http.get(f"{base}/lines", headers={"Host": "cell7.plant.example"})
        assert answer.status_code == 200  # a configured name

    _run(test, api={"hosts": ["cell7.plant.example"]})


def test_a_body_over_the_limit_is_refused_before_it_is_read() -> None:
    async def test(server: LineServer, base: str, http: httpx.AsyncClient) -> None:
        host, port = base.removeprefix("http://").rsplit(":", 1)
        reader, writer = await asyncio.open_connection(host, int(port))
        # 400 MiB announced: refused at once, without a byte of it sent
        writer.write(
            f"POST /lines/cell1/commands HTTP/1.1\r\nHost: {host}:{port}\r\n"
            "Content-Type: application/json\r\nContent-Length: 419430400\r\n\r\n".encode()
        )
        await writer.drain()
        status = await asyncio.wait_for(reader.readline(), 10)
        assert b" 413 " in status, status
        writer.close()

        # no length (chunked): refused once past the limit (not read into memory and run)
        async def chunks() -> AsyncIterator[bytes]:
            yield b'{"command": "ReadStatus", "pad": "'
            for _ in range(8):
                yield b" " * (1 << 20)
            yield b'"}'

        answer = await http.post(
            f"{base}/lines/cell1/commands",
            content=chunks(),
            headers={"Content-Type": "application/json"},
        )
        assert answer.status_code == 413, answer.text
        # a body under the limit is fine
        small = {"command": "ReadStatus", "pad": " " * 1000}
        assert (await http.post(f"{base}/lines/cell1/commands", json=small)).status_code == 200

    _run(test, api={"max_body": 1 << 20})


def test_a_lease_ttl_must_be_finite_and_bounded() -> None:
    async def test(server: LineServer, base: str, http: httpx.AsyncClient) -> None:
        lease = server.lines["cell1"].lease
        who = {"X-Robostar-Who": "gone", "Content-Type": "application/json"}
        for ttl in ("nan", "inf", "-inf", "1e308", "0", "-5", "abc", "3601"):
            answer = await http.post(f"{base}/lines/cell1/lease?ttl={ttl}", headers=who)
            assert answer.status_code == 400, (ttl, answer.text)
            assert "ttl" in answer.json()["message"]
            assert lease.holder is None, ttl
        answer = await http.post(f"{base}/lines/cell1/lease?ttl=2.5", headers=who)
        assert answer.status_code == 200
        assert 2 < answer.json()["expires_at"] - answer.json()["since"] <= 2.5

    _run(test)


def test_bad_numbers_and_non_ascii_headers_are_400_or_401_not_500() -> None:
    async def test(server: LineServer, base: str, http: httpx.AsyncClient) -> None:
        auth = {"Authorization": "Bearer s3cret-token"}
        answer = await http.get(f"{base}/lines", headers=[(b"authorization", b"Bearer \xff")])
        assert answer.status_code == 401
        assert (await http.get(f"{base}/lines", headers=auth)).status_code == 200
        read = {"command": "ReadSpeed", "args": {"channel": 1}}
        for max_age in ("x", float("nan"), -1, [1]):
            answer = await http.post(
                f"{base}/lines/cell1/commands",
                content=json.dumps({**read, "max_age": max_age}),
                headers={**auth, "Content-Type": "application/json"},
            )
            assert answer.status_code == 400 and "max_age" in answer.text, max_age
        for maxsize in ("abc", "0", "-1", "99999999"):
            answer = await http.get(f"{base}/lines/cell1/events?maxsize={maxsize}", headers=auth)
            assert answer.status_code == 400 and "maxsize" in answer.text, maxsize

    _run(test, api={"token": "s3cret-token"})


def test_which_host_headers_a_listen_address_answers() -> None:
    from robostar.serve.http_guard import HostRule, host_of

    assert host_of("Example.COM:8080") == "example.com"
    assert host_of("[::1]:8470") == "::1"
    for bad in (None, "", "::1", "a:b", "[::1", "[::1]x", "evil.example/x"):
        assert host_of(bad) is None, bad
    loopback = HostRule("127.0.0.1")
    assert all(loopback.allows(h) for h in ("127.0.0.1:1", "localhost", "[::1]:2", "localhost."))
    assert not any(loopback.allows(h) for h in ("10.0.0.1", "evil.example", "127.0.0.1.nip.io"))
    wildcard = HostRule("0.0.0.0", ["cell7.plant.example"])
    assert wildcard.allows("192.0.2.7:8470") and wildcard.allows("cell7.plant.example")
    assert not wildcard.allows("evil.example")
    one = HostRule("192.0.2.7")
    assert (
        one.allows("192.0.2.7:8470") and not one.allows("192.0.2.8") and not one.allows("localhost")
    )
    assert HostRule("127.0.0.1", ["*"]).allows("anything.example")


def test_refusals_are_recorded_at_a_capped_rate_and_the_skipped_counted() -> None:
    from robostar.serve.http_guard import Refusals
    from robostar.serve.lease import Who

    class Line:
        def __init__(self) -> None:
            self.entries: list[tuple[str, str]] = []

        def record(self, what: str, who: Who, outcome: str) -> None:
            self.entries.append((what, outcome))

    now = [0.0]
    refusals = Refusals(rate=10, burst=5, clock=lambda: now[0])
    line = Line()
    for _ in range(1000):  # a page's loop of cross-site requests
        refusals.record(line, "POST /x", Who("anonymous", "web"), "no role")  # type: ignore[arg-type]
    assert len(line.entries) == 5 and refusals.skipped == 995
    now[0] = 1.0
    refusals.record(line, "POST /x", Who("anonymous", "web"), "no role")  # type: ignore[arg-type]
    assert "995 refusals before this one not recorded" in line.entries[-1][1]
    assert refusals.skipped == 0


def test_a_line_too_busy_for_one_more_read_is_503_not_a_gateway_error() -> None:
    async def test(server: LineServer, base: str, http: httpx.AsyncClient) -> None:
        line = server.lines["cell1"]
        line._reads_waiting = MAX_QUEUED_READS  # as if that many reads were waiting
        read = {"command": "ReadSpeed", "args": {"channel": 1}, "max_age": 0}
        answer = await http.post(f"{base}/lines/cell1/commands", json=read)
        assert answer.status_code == 503, answer.text
        assert "reads are waiting" in answer.text
        line._reads_waiting = 0
        assert await _speed(base, http) >= 0

    _run(test)
