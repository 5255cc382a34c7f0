"""Over mutual TLS an N1 host is named by its client certificate (its common name, else the
certificate's first e-mail or DNS name) in the line's lease and audit log, not by its address."""

from __future__ import annotations

import asyncio
import socket
import ssl
from pathlib import Path

import pytest
import trustme

from robostar.commands.control import SetSpeed
from robostar.protocol.frame import encode_packet
from robostar.serve import LineConfig, LineServer, ServeConfig

_ACK = b"\x06"
_ETX = 0x03


def _exchange(sock: ssl.SSLSocket, packet: bytes) -> bytes:
    """One N1 exchange by hand: the request, the controller's answer packet, our ACK."""
    sock.sendall(packet)
    answer = b""
    while len(answer) < 2 or answer[-2] != _ETX:  # ETX then the LRC ends the packet
        answer += sock.recv(1)
    sock.sendall(_ACK)
    return answer


@pytest.mark.parametrize(
    ("identities", "common_name", "named"),
    [
        (("cell-host@example.com",), "line 7 host", "line 7 host"),
        (("cell-host@example.com",), None, "cell-host@example.com"),
    ],
)
def test_a_tls_host_is_named_by_its_certificate(
    tmp_path: Path, identities: tuple[str, ...], common_name: str | None, named: str
) -> None:
    ca = trustme.CA()
    server_cert = ca.issue_cert("127.0.0.1", "localhost")
    client_cert = ca.issue_cert(*identities, common_name=common_name)
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
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.5),), faces={"n1": options}
    )

    async def main() -> str | None:
        async with LineServer(config) as server:
            _, port = server.faces["n1"].addresses["cell1"]  # type: ignore[attr-defined]
            line = server.lines["cell1"]

            def host() -> str | None:
                context = ssl.create_default_context(cafile=str(paths["ca"]))
                context.load_cert_chain(str(paths["client"]))
                with (
                    socket.create_connection(("127.0.0.1", port), timeout=5) as raw,
                    context.wrap_socket(raw, server_hostname="127.0.0.1") as tls,
                ):
                    _exchange(tls, encode_packet(SetSpeed(1, 400).encode()))
                    return line.control().holder  # a host's write keeps control

            return await asyncio.to_thread(host)

    holder = asyncio.run(main())
    assert holder is not None and holder.startswith("n1:127.0.0.1:"), holder
    assert holder.endswith(f" ({named})"), holder
