"""The N1 face beyond loopback: it must say who may connect (allow_from or mutual TLS)."""

from __future__ import annotations

import asyncio
import socket
import ssl
from pathlib import Path
from typing import Any

import pytest
import trustme

from robostar.commands.status import ReadStatus
from robostar.errors import UsageError
from robostar.listen import parse_networks
from robostar.protocol.frame import encode_packet
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces import create_face
from robostar.serve.faces.n1.host import AsyncHost

_ACK = b"\x06"
_STX, _ETX = 0x02, 0x03


def _server(**faces: dict[str, Any]) -> LineServer:
    return LineServer(
        ServeConfig(lines=(LineConfig("cell1", "sim://", poll_interval=0.05),), faces=faces)
    )


def test_beyond_loopback_without_allow_from_or_tls_is_refused() -> None:
    options = {"lines": {"cell1": "0.0.0.0:9101"}, "allow_remote": True}
    with pytest.raises(UsageError, match=r"no authentication.*allow_from.*client_ca"):
        create_face("n1", _server(), options)


def test_beyond_loopback_with_allow_from_is_accepted() -> None:
    options = {
        "lines": {"cell1": "0.0.0.0:9101"},
        "allow_remote": True,
        "allow_from": ["10.1.0.0/16"],
    }
    face = create_face("n1", _server(), options)
    assert face.allow_from is not None  # type: ignore[attr-defined]


@pytest.mark.parametrize("bad", ["10.1.0.0/16", ["10.1.0.300"], ["a host"]])
def test_a_bad_allow_from_is_a_clear_error(bad: object) -> None:
    options = {"lines": {"cell1": "127.0.0.1:0"}, "allow_from": bad}
    with pytest.raises(UsageError, match="allow_from"):
        create_face("n1", _server(), options)


def test_half_the_tls_files_or_an_unknown_option_is_refused(tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="all of tls_cert, tls_key and client_ca"):
        create_face("n1", _server(), {"lines": {"cell1": "127.0.0.1:0"}, "tls_cert": "x.pem"})
    with pytest.raises(UsageError, match=r"n1\.tls: unknown option"):
        create_face("n1", _server(), {"lines": {"cell1": "127.0.0.1:0"}, "tls": True})
    missing = str(tmp_path / "missing.pem")
    files = {"tls_cert": missing, "tls_key": missing, "client_ca": missing}
    with pytest.raises(UsageError, match="cannot load the TLS files"):
        create_face("n1", _server(), {"lines": {"cell1": "127.0.0.1:0"}, **files})


def test_allow_from_admits_its_networks_and_loopback_only() -> None:
    host = AsyncHost(lambda name: None)  # type: ignore[arg-type,return-value]
    assert host.admits(("198.51.100.9", 4000))  # no list: everyone the bind reaches
    host.allow_from = parse_networks(["192.0.2.7", "10.1.0.0/16", "2001:db8::/32"])
    assert host.admits(("192.0.2.7", 4000))
    assert host.admits(("10.1.200.3", 4000))
    assert host.admits(("::ffff:10.1.0.9", 4000, 0, 0))
    assert host.admits(("2001:db8::5", 4000, 0, 0))
    assert host.admits(("127.0.0.1", 4000))
    assert host.admits(("::1", 4000, 0, 0))
    assert not host.admits(("192.0.2.8", 4000))
    assert not host.admits(("198.51.100.9", 4000))
    assert not host.admits("/a/unix/socket")


def test_a_peer_outside_allow_from_is_dropped_before_a_session() -> None:
    sessions: list[str] = []

    class Refusing(AsyncHost):
        def admits(self, peername: object) -> bool:
            return False

    def factory(name: str) -> Any:
        sessions.append(name)
        raise AssertionError("no session for a refused peer")

    async def main() -> bytes:
        async with Refusing(factory) as host:
            _, port = await host.start("127.0.0.1", 0, allow_from=["192.0.2.7"])
            reader, writer = await asyncio.open_connection("127.0.0.1", port)
            writer.write(encode_packet(ReadStatus().encode()))
            data = await asyncio.wait_for(reader.read(), 2.0)
            writer.close()
            return data

    assert asyncio.run(main()) == b""
    assert sessions == []


def _ask_status(sock: socket.socket) -> bytes:
    """One AA exchange by hand: the request, the controller's answer packet, our ACK."""
    sock.sendall(encode_packet(ReadStatus().encode()))
    answer = b""
    while len(answer) < 2 or answer[-2] != _ETX:  # ETX then the LRC ends the packet
        answer += sock.recv(1)
    sock.sendall(_ACK)
    return answer


def test_mutual_tls_serves_a_host_with_a_certificate_and_only_it(tmp_path: Path) -> None:
    ca = trustme.CA()
    server_cert = ca.issue_cert("127.0.0.1", "localhost")
    client_cert = ca.issue_cert("cell-host@example.com")
    paths = {name: tmp_path / f"{name}.pem" for name in ("cert", "key", "ca", "client")}
    server_cert.private_key_and_cert_chain_pem.write_to_path(str(paths["cert"]))
    server_cert.private_key_pem.write_to_path(str(paths["key"]))
    ca.cert_pem.write_to_path(str(paths["ca"]))
    client_cert.private_key_and_cert_chain_pem.write_to_path(str(paths["client"]))
    options = {
        "lines": {"cell1": "127.0.0.1:0"},
        "tls_cert": str(paths["cert"]),
        "tls_key": str(paths["key"]),
        "client_ca": str(paths["ca"]),
    }

    def hosts(port: int) -> tuple[bytes, bytes, bytes]:
        with_cert = ssl.create_default_context(cafile=str(paths["ca"]))
        with_cert.load_cert_chain(str(paths["client"]))
        with (
            socket.create_connection(("127.0.0.1", port), timeout=5) as raw,
            with_cert.wrap_socket(raw, server_hostname="127.0.0.1") as tls,
        ):
            answer = _ask_status(tls)
        without_cert = ssl.create_default_context(cafile=str(paths["ca"]))
        with socket.create_connection(("127.0.0.1", port), timeout=5) as raw:
            try:
                with without_cert.wrap_socket(raw, server_hostname="127.0.0.1") as tls:
                    tls.sendall(encode_packet(ReadStatus().encode()))
                    # TLS 1.3 reports the missing certificate after the handshake: an alert or EOF
                    nocert_reply = tls.recv(16)
            except (ssl.SSLError, ConnectionError):
                nocert_reply = b""
        with socket.create_connection(("127.0.0.1", port), timeout=1) as plain:
            plain.sendall(encode_packet(ReadStatus().encode()))
            try:
                plain_reply = plain.recv(16)
            except (ConnectionError, TimeoutError):  # it waits for a TLS record that never comes
                plain_reply = b""
        return answer, nocert_reply, plain_reply

    async def main() -> tuple[bytes, bytes, bytes]:
        async with _server(n1=options) as server:
            _, port = server.faces["n1"].addresses["cell1"]  # type: ignore[attr-defined]
            return await asyncio.to_thread(hosts, port)

    answer, nocert_reply, plain_reply = asyncio.run(main())
    assert answer[0] == _STX and answer[1] == 0x30  # an AA answer, flag OK
    assert nocert_reply == b""  # no certificate, no session: nothing answered
    assert _ACK not in plain_reply  # plain TCP gets a TLS alert at most, never an N1 ACK
